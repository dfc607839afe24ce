"""--gradient on the command line: each field's gradient (:meth:`manifill.results.Result.gradient_data`) into the
point data written, as one vector per point in VTK files and as components elsewhere, with its magnitude."""

from .common import VECTOR_OUTPUTS, gradient_names

__all__ = ["add_gradient"]


def add_gradient(args, r, names, data, suffix):
    """``grad_<name>`` (or ``_x``, ``_y``, ``_z``) and ``grad_<name>_norm`` into ``data``; the names added."""
    added = gradient_names(args, names, suffix)
    if added:
        data.update(r.gradient_data(names, vector=suffix.lower() in VECTOR_OUTPUTS))
    return added
