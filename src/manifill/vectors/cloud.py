"""The connection of a point cloud: the cloud's own frames and weights, transport by the smallest rotation.

A point cloud (:class:`manifill.mesh.pointcloud.Cloud`) has a tangent frame per point (from its neighbours' plane,
normals oriented consistently) and the cotangent weights of its local Delaunay fans. Carrying a tangent vector
from point ``i`` to its neighbour ``j`` turns it by the smallest rotation taking ``i``'s normal to ``j``'s (the
discrete Levi-Civita transport of a sampled surface, as in vector diffusion maps); in the frames that is one
complex number per edge, and the energies of :mod:`manifill.vectors.fill` follow as on a mesh. A cloud has no
faces: no face vectors and no singularities' indices.
"""

import numpy as np

from .connection import Connection

__all__ = ["cloud_connection"]


def _rotate(u, ni, nj):
    """The rows of ``u`` turned by the smallest rotations taking the unit ``ni`` to the unit ``nj`` (row-wise)."""
    c = np.einsum("kc,kc->k", ni, nj)[:, None]
    v = np.cross(ni, nj)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(c > -1.0 + 1e-12, np.einsum("kc,kc->k", v, u)[:, None] / (1.0 + c), 0.0)
    return c * u + np.cross(v, u) + w * v


def cloud_connection(cloud):
    """The :class:`~manifill.vectors.connection.Connection` of a point cloud (faces: none).

    Parameters
    ----------
    cloud : manifill.mesh.pointcloud.Cloud

    Returns
    -------
    Connection
    """
    fr = np.array(cloud.frame, dtype=np.float64)
    fr[:, 1] = np.cross(fr[:, 2], fr[:, 0])
    E = cloud.E
    i, j = E[:, 0], E[:, 1]
    e1 = _rotate(fr[i, 0], fr[i, 2], fr[j, 2])
    rho = np.arctan2(np.einsum("kc,kc->k", e1, fr[j, 1]), np.einsum("kc,kc->k", e1, fr[j, 0]))
    w = -np.asarray(cloud.L[i, j]).ravel()
    return Connection(frames=fr, edges=E, weights=w, transport=rho, face_frames=np.zeros((0, 3, 3)),
                      face_transport=np.zeros((0, 3)), face_curvature=np.zeros(0),
                      F=np.zeros((0, 3), dtype=np.int64))
