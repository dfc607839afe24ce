"""The ``manifill`` command: the command line with every subcommand, ``manifill batch`` included.

The batch layer (:mod:`manifill.cluster`) sits above the command line and adds its subcommand to it when imported;
this entry point imports it first, so that ``import manifill`` and ``import manifill.cli`` need not.
"""

__all__ = ["main"]


def main(argv=None):
    """Run ``manifill ARGV`` (``sys.argv[1:]`` by default): the exit code."""
    from . import cluster  # noqa: F401 - registers `manifill batch`
    from .cli import main as cli_main

    return cli_main(argv)
