"""MNE-Python objects in, MNE-Python objects out: bad EEG channels filled, the field over the whole scalp.

- :func:`head_surface`: the scalp MNE ships (fsaverage's head, in MNE's head coordinates, metres), or a BEM or
  scalp surface you give (``mne.read_bem_surfaces`` dicts, or ``(V, F)`` in head coordinates);
- :func:`electrodes`: the EEG channels' positions from an ``Info`` (its montage or digitisation, head frame);
  MEG sensors are refused with the reason (they sit outside the head, not on the scalp);
- :class:`ScalpMap`: the linear map from the good channels to every vertex of the scalp and to the bad channels,
  built once (one factorisation, one solve per good channel) by any linear manifill method -- the biharmonic by
  default -- and applied to every sample of every epoch;
- :func:`interpolate_bads`: a copy of a ``Raw``, ``Epochs`` or ``Evoked`` with its bad EEG channels filled, as
  MNE's own ``interpolate_bads`` returns (``reset_bads`` likewise);
- :func:`interpolate_to`: the EEG channels of a ``Raw``, ``Epochs`` or ``Evoked`` moved onto another montage (a
  ``DigMontage``: another cap, a standard layout to pool subjects), as MNE's own ``interpolate_to`` does;
- :func:`to_surface`: an ``Evoked`` (or any instance) as a field over the whole scalp, one column per time
  sample: a :class:`manifill.Reconstruction` (write it with ``.save``).

Electrodes are located at their closest point of the scalp (up to ``max_distance``, 3 cm by default: a
template head and a subject's cap differ by a centimetre or two). Needs the ``[mne]`` extra (MNE-Python).
"""

from collections.abc import Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike

from ..errors import OptionError, SampleError
from ..surface.locate import locate_points
from ..surface.reconstruction import Reconstruction
from ..surface.reconstructor import Reconstructor

try:
    import mne
except ImportError:  # the extra, named when used
    raise ImportError("manifill.adapters.mne needs MNE-Python: pip install 'manifill[mne]'") from None

__all__ = ["head_surface", "electrodes", "ScalpMap", "interpolate_bads", "interpolate_to", "to_surface", "forget_maps",
           "MAX_DISTANCE"]

#: How far (metres) an electrode may sit from the scalp surface and still be located on it.
MAX_DISTANCE = 0.03

#: What ``surface=`` takes (:func:`head_surface`), and the recordings the functions take and give.
_Scalp: TypeAlias = "str | Path | dict | tuple[ArrayLike, ArrayLike] | None"
_Recording: TypeAlias = "mne.io.BaseRaw | mne.BaseEpochs | mne.Evoked"


def head_surface(surface: _Scalp = None) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` of a scalp in MNE's head coordinates (metres).

    Parameters
    ----------
    surface : None, str, dict or (V, F)
        None: fsaverage's head as MNE ships it (``mne/data/fsaverage/fsaverage-head.fif``, moved from MRI to head
        coordinates by the shipped ``fsaverage-trans.fif``); a path to a BEM ``.fif``; a surface dict of
        ``mne.read_bem_surfaces`` (its ``rr`` and ``tris``, head or MRI frame: MRI needs the ``trans`` dict under
        ``'trans'``); or ``(V, F)`` arrays already in head coordinates.
    """
    if isinstance(surface, tuple) and len(surface) == 2:
        return np.asarray(surface[0], dtype=np.float64), np.asarray(surface[1], dtype=np.int64)
    if surface is None:  # read once per process
        V, F = _fsaverage_head()
        return V.copy(), F.copy()
    return _surface_of(surface)


@lru_cache(maxsize=1)
def _fsaverage_head():
    return _surface_of(None)


def _surface_of(surface):
    data = Path(mne.__file__).parent / "data" / "fsaverage"
    trans = None
    if surface is None or isinstance(surface, (str, Path)):
        path = data / "fsaverage-head.fif" if surface is None else Path(surface)
        surface = mne.read_bem_surfaces(str(path), verbose=False)[0]
        if surface is not None and path.parent == data:
            trans = mne.read_trans(str(data / "fsaverage-trans.fif"), verbose=False)
    if not isinstance(surface, dict) or "rr" not in surface or "tris" not in surface:
        raise OptionError("surface is not a BEM surface dict (with 'rr' and 'tris'), a path to one, or (V, F) in head "
                          "coordinates; pass one of those, or None for fsaverage's head")
    V = np.asarray(surface["rr"], dtype=np.float64)
    trans = surface.get("trans", trans)
    if surface.get("coord_frame") == mne.io.constants.FIFF.FIFFV_COORD_MRI:
        if trans is None:
            raise OptionError("the surface is in MRI coordinates and no head<->MRI transform came with it; add it "
                              "as surface['trans'] (mne.read_trans) or pass (V, F) in head coordinates")
        to_head = trans if trans["from"] == mne.io.constants.FIFF.FIFFV_COORD_MRI else mne.transforms.invert_transform(
            trans)
        V = mne.transforms.apply_trans(to_head, V)
    return V, np.asarray(surface["tris"], dtype=np.int64)


def electrodes(info: mne.Info, picks: Sequence[str] | None = None) -> tuple[list[str], np.ndarray]:
    """``(names, positions (k, 3))`` of the EEG channels of ``info`` (all, or ``picks`` by name), head frame.

    Parameters
    ----------
    info : mne.Info
        The recording's measurement info (its montage gives the positions).
    picks : list of str, optional
        Channel names (default: every EEG channel).

    Raises
    ------
    OptionError
        MEG channels asked for, channels without positions (no montage), positions in another frame.
    """
    eeg = mne.pick_types(info, meg=False, eeg=True, exclude=[])
    meg = mne.pick_types(info, meg=True, eeg=False, exclude=[])
    names = [info["ch_names"][i] for i in eeg] if picks is None else list(picks)
    bad = [n for n in names if n in {info["ch_names"][i] for i in meg}]
    if bad:
        raise OptionError(f"{bad[0]} is a MEG sensor: it measures the field outside the head, not a potential on the "
                          f"scalp; fill EEG channels (MEG interpolation needs a field model: mne's interpolate_bads)")
    missing = [n for n in names if n not in info["ch_names"]]
    if missing:
        raise OptionError(f"channel {missing[0]!r} is not in the data; pass names of its EEG channels")
    chs = [info["chs"][info["ch_names"].index(n)] for n in names]
    P = np.array([c["loc"][:3] for c in chs], dtype=np.float64).reshape(-1, 3)
    none = [n for n, p in zip(names, P) if not np.isfinite(p).all() or not np.any(p)]
    if none:
        raise OptionError(f"channel {none[0]!r} has no position ({len(none)} without); set a montage first "
                          f"(inst.set_montage('colin27_1020') or the digitisation)")
    frames = {c["coord_frame"] for c in chs}
    if frames != {mne.io.constants.FIFF.FIFFV_COORD_HEAD}:
        raise OptionError(f"the electrodes are in coordinate frame {sorted(frames)}, not the head frame; set the "
                          f"montage with inst.set_montage(...), which puts them in head coordinates")
    return names, P


class ScalpMap:
    """The linear map from ``good`` channels to the scalp's vertices and to the ``targets`` channels.

    Parameters
    ----------
    info : mne.Info
    good : list of str
        The channels measured.
    targets : list of str, (t, 3) array or dict, optional
        Channels of ``info`` to fill (the bad ones), or positions in head coordinates (another montage's), or a
        dict of such positions by name (the names go into error messages).
    surface : as :func:`head_surface`
    method : str
        A method linear in the values (``biharmonic`` by default; ``harmonic``, ``triharmonic``, ``rbf``, ``gp``
        with its range and sigma given, ``gvf-harmonic`` with ``curve_values='hermite'``).
    max_distance : float
        The farthest an electrode may be from the scalp (metres).
    **options
        Of :func:`manifill.reconstruct` (``smoothing`` a number, ...).

    Attributes
    ----------
    V, F : the scalp
    W : (n, k) numpy array
        Every vertex from the ``k`` good channels.
    B : (t, k) numpy array
        The target channels from the good ones.
    """

    def __init__(self, info: mne.Info, good: Sequence[str],
                 targets: Sequence[str] | ArrayLike | Mapping[str, ArrayLike] = (), *, surface: _Scalp = None,
                 method: str = "biharmonic", max_distance: float = MAX_DISTANCE, **options: Any) -> None:
        self.V, self.F = head_surface(surface)
        self.good, (self.targets, labels) = list(good), _targets(targets)
        _, P = electrodes(info, self.good)
        if len(self.good) < 4:
            raise SampleError(f"{len(self.good)} good EEG channels; a scalp map needs at least 4")
        try:
            rec = Reconstructor(self.V, self.F, P, method=method, max_distance=max_distance, fields=len(P),
                                prepare=False, **options)
        except SampleError:
            _on_scalp(self.V, self.F, P, self.good, max_distance)  # an electrode off the scalp: named
            raise
        if not rec.linear:
            raise OptionError(f"method={method!r} as configured is not linear in the values ({rec._why}), so it has "
                              f"no map to apply to every sample; use method='biharmonic' (or a gp with range and "
                              f"sigma given)")
        self.reconstructor = rec
        self.W = np.asarray(rec.matrix(form="operator") @ np.eye(len(P)))
        self.B = np.zeros((0, len(P)))
        if len(self.targets):
            T = electrodes(info, self.targets)[1] if labels is None else self.targets
            loc = _on_scalp(self.V, self.F, T, self.targets if labels is None else labels, max_distance)
            self.B = np.einsum("tc,tck->tk", loc.bary, self.W[loc.corners])

    def apply(self, data: ArrayLike) -> np.ndarray:
        """``(targets, ...)`` values of the target channels from the good channels' ``(good, ...)`` data."""
        X = np.asarray(data, dtype=np.float64)
        return np.tensordot(self.B, X, axes=(1, 0))


def _targets(targets):
    """``(names, None)`` or ``((t, 3) positions, their labels)``: the channels a map fills (a dict: positions by
    name)."""
    if len(targets) == 0:
        return [], None
    arr = np.asarray(list(targets.values()) if isinstance(targets, dict) else targets)
    if arr.dtype.kind not in "fiu":
        return [str(t) for t in targets], None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise OptionError(f"targets of shape {arr.shape} are neither channel names nor (t, 3) positions; pass names "
                          f"of channels in info, or positions in head coordinates (metres)")
    labels = list(targets) if isinstance(targets, dict) else [f"target {i}" for i in range(len(arr))]
    return arr.astype(np.float64), labels


def _on_scalp(V, F, P, names, max_distance):
    """The electrodes ``P`` located on the scalp; one line naming the farthest of those beyond ``max_distance``."""
    loc = locate_points(V, F, P, max_distance=np.inf)
    far = np.flatnonzero(~(loc.distance <= max_distance))
    if far.size:
        i = far[np.argmax(np.nan_to_num(loc.distance[far], nan=np.inf))]
        raise SampleError(f"{far.size} electrodes lie farther than {100 * max_distance:g} cm from the scalp ("
                          f"{names[i]!s} at {100 * loc.distance[i]:.1f} cm); pass a scalp that fits the cap "
                          f"(surface=), or max_distance= in metres")
    return loc


#: The scalp maps built lately, by what makes them (a montage's good and bad channels' positions, the surface, the
#: method and options): recordings with the same cap and the same bads reuse one.
_MAPS: dict = {}
MAPS_KEPT = 8


def _scalp_map(info, good, bads, surface, method, options):
    """The map from ``good`` to ``bads`` (names in ``info``, or a dict of positions by name), kept by what makes
    it."""
    if surface is not None and not (isinstance(surface, tuple) and len(surface) == 2):
        return ScalpMap(info, good, bads, surface=surface, method=method, **options)  # a file or dict: no key
    placed = isinstance(bads, dict)
    to = np.array(list(bads.values()), dtype=np.float64) if placed else electrodes(info, bads)[1]
    where = [electrodes(info, good)[1].tobytes(), to.tobytes()]
    mesh = None if surface is None else tuple(np.ascontiguousarray(a).tobytes() for a in surface)
    names = ("positions", *bads) if placed else tuple(bads)
    key = (tuple(good), names, *where, mesh, method, repr(sorted(options.items())))
    if key not in _MAPS:
        if len(_MAPS) >= MAPS_KEPT:
            _MAPS.pop(next(iter(_MAPS)))
        _MAPS[key] = ScalpMap(info, good, bads, surface=surface, method=method, **options)
    return _MAPS[key]


def forget_maps() -> None:
    """Drop the scalp maps kept between calls (the next :func:`interpolate_bads` builds its map again)."""
    _MAPS.clear()


def _eeg_bads(inst):
    eeg = set(inst.info["ch_names"][i] for i in mne.pick_types(inst.info, meg=False, eeg=True, exclude=[]))
    bads = [b for b in inst.info["bads"] if b in eeg]
    good = [n for n in inst.info["ch_names"] if n in eeg and n not in bads]
    return bads, good


def interpolate_bads(inst: _Recording, *, reset_bads: bool = True, surface: _Scalp = None, method: str = "biharmonic",
                     **options: Any) -> _Recording:
    """A copy of ``inst`` (``Raw``, ``Epochs`` or ``Evoked``) with its bad EEG channels filled.

    The map is built once from the good channels' positions (:class:`ScalpMap`) and applied to every sample of
    every epoch (and kept for the next recording with the same cap, bads and method); data not loaded are loaded
    into the copy. ``reset_bads`` takes the channels filled out of
    ``info['bads']`` (other bads, EOG or MEG, stay). With no bad EEG channel the copy comes back unchanged.

    Parameters
    ----------
    inst : mne.io.Raw, mne.Epochs or mne.Evoked
        The recording; its bad EEG channels are ``info['bads']``.
    reset_bads : bool, optional
        Take the filled channels out of ``info['bads']`` (default).
    surface : (V, F) or None, optional
        The scalp to interpolate on, in the head frame (default: the shipped fsaverage scalp).
    method : str, optional
        A method of :func:`manifill.reconstruct` that is linear in the values (default ``'biharmonic'``).
    **options
        More options of :func:`manifill.reconstruct` (``max_distance`` defaults to the scalp's tolerance).

    Raises
    ------
    OptionError
        Channels without positions, a method that is not linear.
    """
    bads, good = _eeg_bads(inst)
    out = inst.copy()
    if not bads:  # nothing to fill: the copy as it is (as MNE's own does, which warns)
        return out
    if not getattr(out, "preload", True):
        out.load_data()  # the copy's data read from its file
    m = _scalp_map(out.info, good, bads, surface, method, options)
    names = out.info["ch_names"]
    gi, bi = [names.index(n) for n in good], [names.index(n) for n in bads]
    data = out.data if isinstance(out, mne.Evoked) else out._data  # noqa: SLF001 (MNE fills channels so too)
    if data.ndim == 3:  # epochs x channels x times
        data[:, bi, :] = np.einsum("bk,ekt->ebt", m.B, data[:, gi, :])
    else:
        data[bi] = m.B @ data[gi]
    if reset_bads:
        out.info["bads"] = [b for b in out.info["bads"] if b not in bads]
    return out


def interpolate_to(inst: _Recording, sensors: mne.channels.DigMontage, *, surface: _Scalp = None,
                   method: str = "biharmonic", **options: Any) -> _Recording:
    """A new instance (``Raw``, ``Epochs`` or ``Evoked``) whose EEG channels are those of the montage ``sensors``.

    Their values come from the good EEG channels of ``inst`` through one :class:`ScalpMap` (kept for the next call
    with the same caps); the other channels (EOG, stimulus, ...) stay, in their places, the new EEG channels where
    the first EEG channel was. Bad EEG channels are dropped (their values are not used); other bads stay marked;
    the rest of ``inst`` (filters, events, metadata, annotations) is kept, but EEG projectors (an average
    reference) are not: set the reference again on the new channels.

    Parameters
    ----------
    inst : mne.io.Raw, mne.Epochs or mne.Evoked
    sensors : mne.channels.DigMontage
        The target montage (e.g. ``mne.channels.make_standard_montage('colin27_1020')``, or a cap's own), placed in
        head coordinates by its fiducials as ``set_montage`` places it.
    surface, method, **options
        As :func:`interpolate_bads`.

    Raises
    ------
    OptionError
        ``sensors`` not a montage or without channel positions, channels of ``inst`` without positions, a method
        that is not linear.
    """
    if not isinstance(sensors, mne.channels.DigMontage):
        raise OptionError(f"sensors is a {type(sensors).__name__}, not an mne.channels.DigMontage; pass a montage "
                          f"(mne.channels.make_standard_montage('colin27_1020'), or your cap's)")
    where = sensors.get_positions()["ch_pos"]
    names = list(where)
    if not names:
        raise OptionError("the montage has no channel positions; pass one with its electrodes' positions")
    none = [n for n, p in where.items() if not np.isfinite(p).all()]
    if none:
        raise OptionError(f"the montage's channel {none[0]!r} has no position ({len(none)} without); give every "
                          f"channel of the montage a position, or drop those")
    bads, good = _eeg_bads(inst)
    if not good:
        raise OptionError("inst has no good EEG channel to interpolate from; mark fewer channels bad")
    order = inst.info["ch_names"]
    eeg = [n for n in order if n in set(good) | set(bads)]
    rest = [n for n in order if n not in eeg]
    clash = [n for n in names if n in rest]
    if clash:
        raise OptionError(f"the montage's channel {clash[0]!r} has the name of a channel of the data that is not EEG; "
                          f"rename it in the montage (montage.rename_channels) or drop it from the data")
    target = mne.create_info(names, inst.info["sfreq"], "eeg")
    target.set_montage(sensors)  # head coordinates, as MNE places a montage
    m = _scalp_map(inst.info, good, dict(zip(names, electrodes(target)[1])), surface, method, options)
    src = inst.copy()
    if not getattr(src, "preload", True):
        src.load_data()
    moved = np.matmul(m.B, src.get_data(picks=good))  # (targets, times), or (epochs, targets, times)
    target.set_meas_date(src.info["meas_date"])
    if isinstance(src, mne.BaseEpochs):
        new = mne.EpochsArray(moved, target, events=src.events, tmin=src.tmin, event_id=src.event_id,
                              on_missing="ignore", verbose=False)
    elif isinstance(src, mne.Evoked):
        new = mne.EvokedArray(moved, target, tmin=src.tmin, nave=src.nave, verbose=False)
    else:
        new = mne.io.RawArray(moved, target, first_samp=src.first_samp, verbose=False)
    # the output is the copy itself (its filters, events, metadata, annotations, ...): its other channels kept, or,
    # with none, one EEG channel kept under a free name until the new ones are in
    spare = next(f"{eeg[0]}~{i}" for i in range(len(names) + 1) if f"{eeg[0]}~{i}" not in names)
    out = src.pick(rest or eeg[:1])
    if not rest:
        out.rename_channels({eeg[0]: spare})
    out.add_channels([new], force_update_info=True)
    if not rest:
        return out.drop_channels([spare])
    at = order.index(eeg[0])
    out.reorder_channels([n for n in order[:at] if n in rest] + names + [n for n in order[at:] if n in rest])
    return out


def to_surface(inst: _Recording, *, surface: _Scalp = None, method: str = "biharmonic",
               **options: Any) -> Reconstruction:
    """The EEG field over the whole scalp: a :class:`manifill.Reconstruction` of ``(n_vertices, n_times)`` values
    (an ``Epochs``: its average), from the good channels.

    Parameters
    ----------
    inst : mne.io.Raw, mne.Epochs or mne.Evoked
        The recording (an ``Epochs`` is averaged first).
    surface : (V, F) or None, optional
        The scalp, in the head frame (default: the shipped fsaverage scalp).
    method : str, optional
        Any method of :func:`manifill.reconstruct` (default ``'biharmonic'``).
    **options
        More options of :func:`manifill.reconstruct`.
    """
    bads, good = _eeg_bads(inst)
    evoked = inst.average() if isinstance(inst, mne.BaseEpochs) else inst
    V, F = head_surface(surface)
    _, P = electrodes(evoked.info, good)
    data = evoked.get_data(picks=good)
    rec = Reconstructor(V, F, P, method=method, max_distance=options.pop("max_distance", MAX_DISTANCE),
                        fields=data.shape[1], **options)
    return rec.apply(data)
