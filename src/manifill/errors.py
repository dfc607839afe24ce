"""manifill's exceptions: every bad input ends in one of these, with a one-line message."""

__all__ = [
    "ManifillError",
    "MeshError",
    "SampleError",
    "SolveError",
    "ReadError",
    "WriteError",
    "OptionError",
    "ResourceError",
]


class ManifillError(ValueError):
    """Base class of manifill's errors.

    The message is one line that names the problem and the fix. It subclasses
    ``ValueError`` so that code catching ``ValueError`` keeps working.
    """


class MeshError(ManifillError):
    """The domain is malformed or unusable as given.

    A triangle mesh ``(V, F)``, a tetrahedral mesh ``(V, T)``, a voxel mask with its
    spacing and origin, or a Laplacian given in place of a mesh.
    """


class SampleError(ManifillError):
    """The samples ``(idx, vals)`` are malformed: their indices, values, positions or fixed voxels."""


class SolveError(ManifillError):
    """The problem has no unique solution as posed (e.g. a component with no fixed vertex)."""


class OptionError(ManifillError):
    """A keyword option is not one of its allowed values."""


class ReadError(ManifillError):
    """A file could not be read as a mesh or as samples."""


class WriteError(ManifillError):
    """A result could not be written."""


class ResourceError(ManifillError):
    """The problem is predicted not to fit in the memory available; nothing was attempted."""
