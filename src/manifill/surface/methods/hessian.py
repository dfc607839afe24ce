"""``method='hessian'`` and ``'hessian-curved'``: the squared Hessian with the samples fixed, for open surfaces.

The biharmonic energy's natural boundary conditions bend a field at a surface's boundary (a scalp's
rim, a helmet's edge, a cap, a scan with holes); the Hessian energy's do not: its fill reproduces
linear fields on any flat mesh, boundary or not (:mod:`manifill.mesh.hessian`). ``hessian`` is the
energy of Stein et al. (2018) in ambient coordinates, manifill's own (equal to libigl's
``hessian_energy``); ``hessian-curved`` is their energy for curved surfaces (2020), libigl's
``curved_hessian_energy`` (the ``[hessian]`` extra). Everything else is the biharmonic method's: samples at
vertices or inside faces, ``bounds`` (both modes), ``smoothing``, many fields, the prepared map; the solver
policy of a 4th-order energy (:class:`manifill.surface.polyharmonic.PolyharmonicSolver.settings`). No std:
the Hessian energy is not read as a Gaussian field here.
"""

from ...errors import OptionError
from ...mesh.hessian import curved_hessian_energy, hessian_energy
from ...validate import unit_scale
from .energy import Energy

__all__ = ["Hessian", "HESSIAN", "HESSIAN_CURVED"]


class Hessian(Energy):
    """A Hessian energy with the samples fixed (see the module docstring)."""

    gives_std = False
    needs_triangles = True
    needs_faces = True

    def __init__(self, name, build, summary):
        super().__init__(name, 2, summary)
        self.build = build
        self.smooth_gradient = True

    def energy_of(self, surface):
        """The energy matrix of a triangle mesh (on positions divided by a power of two: the same minimiser)."""
        if surface.F is None:
            raise OptionError(f"method={self.name!r} needs triangles, and this surface has none (a point cloud or a "
                              f"digital surface); use method='biharmonic'")
        return self.build(surface.V / unit_scale(surface.V), surface.F)


HESSIAN = Hessian("hessian", hessian_energy, "the squared Hessian with the samples fixed: as smooth as the biharmonic, "
                  "exact on linear fields, no bending at a surface's boundary")
HESSIAN_CURVED = Hessian("hessian-curved", curved_hessian_energy, "the Hessian energy of curved surfaces (libigl's, "
                         "the [hessian] extra): the same, with the surface's curvature accounted for")
