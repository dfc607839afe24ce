"""The ``manifill`` command line: ``main(argv)`` and one module per subcommand (no numerics here)."""

from .main import build_parser, main

__all__ = ["main", "build_parser"]
