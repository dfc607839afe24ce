"""``manifill demo``: the built-in example."""

from ..demo import run_demo
from .options import output_args

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill demo``."""
    s = sub.add_parser("demo", help="run the built-in example (nothing downloaded)",
                       description="Reconstruct a known field on a generated sphere, write the results "
                                   "and print the error.")
    s.add_argument("-o", "--output", default="manifill-demo", help="output folder (default: ./manifill-demo)")
    s.add_argument("--level", type=int, default=6, choices=range(1, 8), metavar="L",
                   help="the sphere's subdivision level, 1-7 (default 6: 40,962 vertices)")
    s.add_argument("--no-pictures", action="store_true",
                   help="skip the paper's figures and the viewer (they need the [viz] and [volume] extras)")
    output_args(s)
    s.set_defaults(func=run)


def run(args):
    """``manifill demo``."""
    report = run_demo(args.output, level=args.level, pictures=not args.no_pictures)
    print(report["text"])
    return 0
