"""The default: what ``method=None`` (or ``method='default'``) runs, a named preset chosen by measurement.

Among the methods that never leave the samples' range and take at most 4x the earlier
default's time at 655k vertices, the lowest median relative RMSE over the whole accuracy
benchmark (``python -m bench accuracy``; README, "Which method when"): the paper's
pipeline with monotone cubic curve values, its fill bounded by the samples' range. A
preset fills in only the options the caller did not give; ``report['preset']`` names it
and ``report['method']``, ``report['curve_values']`` and the bounds say what ran.
"""

from dataclasses import dataclass

__all__ = ["DEFAULT", "Preset"]


@dataclass(frozen=True)
class Preset:
    """A named configuration: a method and the options it sets unless the caller gives them."""

    name: str
    method: str
    options: dict
    summary: str = ""


DEFAULT = Preset("default", "gvf-harmonic", {"curve_values": "monotone", "bounds": "samples"},
                 "the paper's pipeline with monotone curve values, bounded by the samples' range: fast, never "
                 "leaves the range")
