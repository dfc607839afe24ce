"""--gradient on the command line: each field's gradient (:meth:`manifill.results.Result.gradient`) into the
point data written, as one vector per point in VTK files and as components elsewhere, with its magnitude."""

import numpy as np

from .common import VECTOR_OUTPUTS, gradient_names

__all__ = ["add_gradient"]


def add_gradient(args, r, names, data, suffix):
    """``grad_<name>`` (or ``_x``, ``_y``, ``_z``) and ``grad_<name>_norm`` into ``data``; the names added."""
    added = gradient_names(args, names, suffix)
    if not added:
        return []
    G = r.gradient()  # values' shape + (3,)
    if G.ndim == r.values.ndim + 1 and len(names) == 1 and r.values.ndim == r.point_ndim:
        G = G[..., None, :]  # one field: its axis put back
    for j, name in enumerate(names):
        g = G[..., j, :]
        if suffix.lower() in VECTOR_OUTPUTS:
            data[f"grad_{name}"] = g
        else:
            data.update({f"grad_{name}_{c}": g[..., i] for i, c in enumerate("xyz")})
        data[f"grad_{name}_norm"] = np.linalg.norm(g, axis=-1)
    return added
