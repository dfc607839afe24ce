"""manifill's version: one string at the base of the package (the distribution's metadata reads it from here)."""

__all__ = ["__version__"]

__version__ = "0.1.0"
