"""The names of fields on disk: manifill's mask arrays, and what each format can store as a name.

Mask and label arrays have one naming scheme everywhere, the result family's
(:mod:`manifill.results`, re-exported here): :data:`SAMPLE_MASK`,
:data:`CURVE_MASK`, :data:`PATCH_LABEL`, :data:`BOUNDARY_MASK`. Fields keep
their names where the format allows any text (VTU, VTP, VTI); PLY and legacy VTK
store plain words, so there other characters become ``_`` (:func:`stored_names`
says what was renamed). A name no format can store (empty, or with line breaks or
other control characters) is refused by :func:`check_field_names`.
"""

import re
from pathlib import Path

from ..errors import WriteError
from .formats import find_format
from ..results import BOUNDARY_MASK, CURVE_MASK, PATCH_LABEL, RESERVED_NAMES, SAMPLE_MASK

__all__ = ["SAMPLE_MASK", "CURVE_MASK", "PATCH_LABEL", "BOUNDARY_MASK", "RESERVED_NAMES", "check_field_names",
           "stored_names"]

_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def check_field_names(names, path=None, *, masks=True):
    """Refuse field names that no format can store, or that a mask of manifill's uses.

    Parameters
    ----------
    names : iterable of str
    path : str or Path, optional
        The output (for the message).
    masks : bool, optional
        Also refuse :data:`RESERVED_NAMES` (the output gets those masks).

    Raises
    ------
    WriteError
        An empty name, a name with a line break or another control character,
        a comma or quote for a CSV ``path``, or a reserved name; the message
        says how to rename it.
    """
    where = f"{Path(path).name}: " if path is not None else ""
    fmt = None if path is None else find_format("values", path, writing=True)
    text = fmt is not None and fmt.text
    for name in names:
        name = str(name)
        if not name.strip():
            raise WriteError(f"{where}a field has an empty name; give every value column a name")
        if _CONTROL.search(name):
            raise WriteError(f"{where}field name {name!r} holds a line break or control character, which no mesh "
                             f"format can store; rename the value column")
        if text and ("," in name or '"' in name):
            raise WriteError(f"{where}field name {name!r} holds a comma or quote, which a CSV header cannot hold; "
                             f"rename the value column or write .npy")
        if masks and name in RESERVED_NAMES:
            raise WriteError(f"{where}field name {name!r} is the name of manifill's mask in the output; rename the "
                             f"value column")


def stored_names(names, fmt):
    """The name each field gets in a file of the format ``fmt`` (a :class:`manifill.io.formats.Format`).

    VTU, VTP and VTI keep any text; PLY, legacy VTK and Gmsh hold plain ASCII words (``fmt.plain_names``), so
    there every other character becomes ``_``; a name the format's reader would take for something else
    (``fmt.reserved``: PLY's ``x``, ``y``, ``z`` and a leading digit; VTK's ``metadata`` lines) or a repeated one
    gets a ``field_`` prefix.

    Parameters
    ----------
    names : iterable of str
    fmt : manifill.io.formats.Format

    Returns
    -------
    dict of str to str

    Raises
    ------
    WriteError
        As :func:`check_field_names` (reserved names allowed).

    Examples
    --------
    >>> from manifill.io.formats import find_format
    >>> stored_names(["temp (K)", "x"], find_format("mesh", "a.ply"))
    {'temp (K)': 'temp__K_', 'x': 'field_x'}
    >>> stored_names(["temp (K)"], find_format("mesh", "a.vtu"))
    {'temp (K)': 'temp (K)'}
    """
    names = [str(n) for n in names]
    check_field_names(names, masks=False)
    if not fmt.plain_names:
        return {n: n for n in names}
    out, taken = {}, set()
    for name in names:
        key = re.sub(r"[^0-9A-Za-z_]", "_", name)
        if fmt.reserved is not None and fmt.reserved(key):
            key = f"field_{key}"
        while key in taken:
            key = f"field_{key}"
        taken.add(key)
        out[name] = key
    return out
