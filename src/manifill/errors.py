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
    """The mesh ``(V, F)`` is malformed or unusable as given."""


class SampleError(ManifillError):
    """The samples ``(idx, vals)`` or the fixed set ``(b, bc)`` are malformed."""


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
