"""Adapters: manifill where its users already work (each an optional extra that fails only when used).

- :mod:`manifill.adapters.sklearn` - a scikit-learn estimator over a fixed mesh or point cloud (``[sklearn]``)
- :mod:`manifill.adapters.mne` - bad EEG channels filled and fields on the scalp from MNE-Python objects (``[mne]``)
- :mod:`manifill.adapters.globe` - stations by longitude and latitude to CF lon/lat grids with xarray (``[xarray]``)
"""
