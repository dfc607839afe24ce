"""The default: what ``method=None`` (or ``method='default'``) runs, a named preset chosen by measurement.

The rule (issue 37; README, "Which method when"): among the configurations that never leave the samples'
range and take at most 4x the paper's pipeline's time and at most 0.25x libigl's ``harmonic(k=2)`` at 41k, 163k
and 655k vertices with 100 and 1,000 samples, the lowest median relative RMSE over the whole accuracy benchmark
(``python -m bench.default_rule``, ``python -m bench.default_targets``): the biharmonic energy with the samples
fixed, its field projected onto the samples' range (``bounds='samples', bounds_mode='project'``; median 0.0468
over 37 cells, equal to libigl's biharmonic clipped to the range, against 0.0749 for the pipeline with monotone
curves that was the default before). A surface without triangles for a mass matrix (a voxel mask's digital
surface) cannot take the biharmonic energy: there the default is its :attr:`Preset.fallback`, the paper's
pipeline with monotone curve values bounded by the samples' range. A preset fills in only the options the
caller did not give; ``report['preset']`` names it and ``report['method']`` and ``report['bounds']`` say what
ran.
"""

from dataclasses import dataclass

__all__ = ["DEFAULT", "PIPELINE_DEFAULT", "Preset"]


@dataclass(frozen=True)
class Preset:
    """A named configuration: a method and the options it sets unless the caller gives them.

    ``fallback``: the preset used instead on a surface without a mass matrix, where this one's method needs one.
    """

    name: str
    method: str
    options: dict
    summary: str = ""
    fallback: object = None


#: The default where the surface has no triangles (a voxel mask's digital surface): the paper's pipeline.
PIPELINE_DEFAULT = Preset("default", "gvf-harmonic", {"curve_values": "monotone", "bounds": "samples"},
                          "the paper's pipeline with monotone curve values, bounded by the samples' range")
DEFAULT = Preset("default", "biharmonic", {"bounds": "samples", "bounds_mode": "project"},
                 "the biharmonic fill projected onto the samples' range: the most accurate of the benchmark that "
                 "never leaves the range, one solve", fallback=PIPELINE_DEFAULT)
