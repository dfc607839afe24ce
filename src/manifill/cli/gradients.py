"""--gradient on the command line: each field's gradient (:meth:`manifill.results.Result.gradient_data`) into the
point data written, as one vector per point in VTK files and as components elsewhere, with its magnitude."""

from .common import gradient_names, vector_output

__all__ = ["add_gradient"]


def add_gradient(args, r, names, data, path):
    """``grad_<name>`` (or ``_x``, ``_y``, ``_z``) and ``grad_<name>_norm`` into ``data`` for the output ``path``;
    the names added."""
    added = gradient_names(args, names, path)
    if added:
        data.update(r.gradient_data(names, vector=vector_output(path)))
    return added
