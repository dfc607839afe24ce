"""``manifill cv MESH SAMPLES``: which method to trust, by cross-validation on the samples themselves."""

import time

from ..errors import OptionError
from ..surface.options import Options
from .common import barriers_arg, bounds_arg, chosen_field, levels, load, smoothing_arg
from .options import choices_of, cloud_args, default_of, sample_args

__all__ = ["add_parser", "run", "parse_methods", "parse_folds"]


def add_parser(sub):
    """Register ``manifill cv``."""
    s = sub.add_parser("cv", help="cross-validate the methods on the samples and recommend one",
                       description="Hold out each of K random groups of samples in turn, reconstruct from the "
                                   "others with every candidate method and measure the error at the held-out "
                                   "samples (RMSE over the samples' range). Prints one line per method, best "
                                   "first, and a recommendation. Writes nothing.")
    sample_args(s)
    s.add_argument("--methods", default=None, metavar="LIST",
                   help="comma-separated candidates, each NAME or NAME:OPTION=VALUE[:OPTION=VALUE], e.g. "
                        "'harmonic,biharmonic:bounds=samples,gvf-harmonic:curve_values=monotone,rbf' (bounds "
                        "LO/HI for a range); default: gvf-harmonic (also with curve_values=monotone), harmonic, "
                        "biharmonic (also bounded), triharmonic, rbf")
    s.add_argument("--folds", default="10", metavar="K|loo",
                   help="number of folds (>= 2), or 'loo' to leave one sample out at a time (default: 10)")
    s.add_argument("--seed", type=int, default=0, help="seed of the random split (default: 0)")
    s.add_argument("--field", default=None, metavar="NAME",
                   help="cross-validate this field only (default: all fields together)")
    s.add_argument("--weights", choices=choices_of("weights"), default=default_of("weights"),
                   help=f"Laplacian weights (default: {default_of('weights')})")
    s.add_argument("--solver", choices=choices_of("solver"), default=default_of("solver"),
                   help=f"linear solver (default: {default_of('solver')})")
    s.add_argument("--distance", choices=choices_of("distance"), default=default_of("distance"),
                   help=f"partition distance (default: {default_of('distance')})")
    cloud_args(s)
    s.set_defaults(func=run)


def parse_folds(text):
    """``--folds``: an integer >= 2 or ``loo``."""
    if text == "loo":
        return text
    try:
        folds = int(text)
    except ValueError:
        folds = None
    if folds is None or folds < 2:
        raise OptionError(f"--folds {text!r} is neither an integer >= 2 nor 'loo' (e.g. --folds 5)")
    return folds


def _value(key, text):
    if key == "bounds":
        return bounds_arg(text.replace("/", ","))
    if key == "smoothing":
        return smoothing_arg(text)
    if key in ("levels", "maxiter"):
        return levels(text) if key == "levels" else int(text)
    if key == "tol":
        return float(text)
    return text


def parse_methods(text):
    """``--methods``: a list of names and ``(name, options)`` pairs (None: the defaults).

    Examples
    --------
    >>> parse_methods("harmonic,biharmonic:bounds=samples")
    ['harmonic', ('biharmonic', {'bounds': 'samples'})]
    """
    if text is None:
        return None
    out = []
    for entry in (e.strip() for e in text.split(",")):
        if not entry:
            continue
        name, *opts = entry.split(":")
        if not opts:
            out.append(name)
            continue
        options = {}
        for o in opts:
            key, eq, value = o.partition("=")
            if not eq or not key:
                raise OptionError(f"--methods entry {entry!r}: {o!r} is not OPTION=VALUE "
                                  f"(e.g. biharmonic:bounds=samples)")
            try:
                options[key.replace("-", "_")] = _value(key.replace("-", "_"), value)
            except ValueError:
                raise OptionError(f"--methods entry {entry!r}: {key}={value!r} is not a valid value") from None
        out.append((name, options))
    if not out:
        raise OptionError("--methods is empty; list at least one method (e.g. --methods harmonic,rbf)")
    return out


def run(args):
    """``manifill cv MESH SAMPLES``: the table and a recommendation, exit 0."""
    from ..surface.crossval import cross_validate

    methods, folds = parse_methods(args.methods), parse_folds(args.folds)
    V, F, S, read = load(args, keep_points=True, points=True, options=Options.build(barriers=barriers_arg(args)))
    # positions stay positions: the energy methods and rbf constrain them where they are, as reconstruct does
    where = dict(idx=S.idx, vals=S.vals) if S.points is None else dict(idx=S.points, vals=S.point_vals,
                                                                         max_distance=args.max_distance)
    names = list(S.names)
    if args.field is not None:
        name = chosen_field(args, names)
        where["vals"], names = where["vals"][:, [names.index(name)]], [name]
    t0 = time.perf_counter()
    cv = cross_validate(V, F, **where, methods=methods, folds=folds, seed=args.seed, weights=args.weights,
                        solver=args.solver, distance=args.distance, duplicates=args.duplicates,
                        neighbours=args.neighbours, barriers=read.fill.barriers)
    seconds = time.perf_counter() - t0
    print(f"{len(V):,} vertices, {cv.samples:,} samples ({len(names)} field(s): {', '.join(names)})")
    if S.points is not None:
        print("samples at positions: the energy methods and rbf use them where they are, the others the nearest "
              "vertex")
    print(cv.table())
    print(f"recommendation: {cv.recommendation}")
    print(f"time: {seconds:.2f} s")
    return 0
