"""What the command line's subcommands share: reading the inputs, checking every output before the work, writing.

All outputs of one command (``-o``, ``--render``, ``--html``) are checked before
anything is read or computed: a known extension, an existing and writable folder,
no output equal to an input or to another output. Results are written with
manifill's mask arrays under their fixed names (:data:`manifill.io.SAMPLE_MASK`,
...), and a line says where a format hides the fields from a common reader. No numerics
here: masks come from the results (:meth:`manifill.results.Result.masks`), value ranges
from :func:`manifill.report.value_ranges`.
"""

import sys
from pathlib import Path

from ..errors import OptionError, SampleError, WriteError
from ..io import (MESH_FORMATS, SAMPLE_FORMATS, VALUE_FORMATS, check_field_names, format_note, read_barriers,
                  read_mesh_file, read_samples, write_mesh)
from ..mesh.clean import clean_mesh
from .. import progress
from ..report import uncertainty_lines, value_ranges
from ..results import TRUSTED
from ..surface.barriers import renumber
from ..surface.samples import Samples
from ..viz.render import render_fields
from ..viz.viewer import write_html
from ..io.formats import written_as
from .outputs import check_outputs
from ..surface.methods.registry import METHODS, method_of

__all__ = ["check_order", "load", "check_outputs", "write_surface", "levels", "bounds_arg", "smoothing_arg",
           "step_bar", "print_time", "pictures", "chosen_field", "surface_outputs", "check_names", "print_ranges",
           "err", "std_methods", "wants_std", "uncertainty_opts", "std_names", "print_uncertainty", "check_draws",
           "add_draws", "vector_output", "gradient_names", "barriers_arg", "check_barrier_numbering"]


def barriers_arg(args):
    """``--barriers FILE`` read (None without it)."""
    path = getattr(args, "barriers", None)
    return None if path is None else read_barriers(path)


def check_order(mesh, samples):
    """Refuse MESH and SAMPLES given the wrong way round (a samples file first, a mesh second), in one line."""
    m, s = Path(str(mesh)).suffix.lower(), Path(str(samples)).suffix.lower()
    if m in SAMPLE_FORMATS and s in MESH_FORMATS and s not in SAMPLE_FORMATS:
        raise OptionError(f"MESH is {Path(str(mesh)).name}, a samples file, and SAMPLES is {Path(str(samples)).name}, "
                          f"a mesh: did you swap them? the order is MESH SAMPLES")


def check_barrier_numbering(mesh, barriers):
    """Refuse barriers given by vertex index on a mesh file that does not keep its vertex numbers (STL)."""
    if mesh.vertex_numbering and isinstance(barriers, list) and any(getattr(p, "ndim", 0) == 1 for p in barriers):
        raise OptionError(f"{mesh.vertex_numbering}; give the barriers as positions (a .csv of x,y,z) or per-face "
                          f"labels (.npy) instead of vertex indices")


def load(args, keep_points=False, points=False, options=None):
    """Read mesh and samples (checked against the mesh's vertex numbering), optionally cleaning the mesh first.

    ``keep_points``: samples given as positions keep them (``S.points``), for the
    energy methods, which locate them on the surface. ``points``: take a point cloud too
    (a file of points without faces: ``F`` None). ``options``: the run's Options, whose barriers
    (``--barriers``, vertex paths in the file's numbering) are checked against it and renumbered by ``--clean``.

    Returns
    -------
    V, F : numpy arrays (F None for a point cloud)
    S : manifill.surface.samples.Samples
    options : the Options, barriers in the mesh's numbering (with ``options`` only)
    """

    check_order(args.mesh, args.samples)
    mesh = read_mesh_file(args.mesh, points=points)
    V, F = mesh.V, mesh.F
    barriers = None if options is None else options.fill.barriers
    check_barrier_numbering(mesh, barriers)
    if F is None:
        if args.clean:
            raise OptionError(f"{Path(args.mesh).name} is a point cloud (no faces), and --clean welds meshes; leave "
                              f"--clean out (merge duplicate points yourself)")
        print(f"point cloud: {len(V):,} points, no faces")
    # vertex indices refer to the file's numbering, so samples are read against it
    read = dict(duplicates=args.duplicates, max_distance=args.max_distance, vertex_numbering=mesh.vertex_numbering,
                keep_points=keep_points)
    S = read_samples(args.samples, V, **read)
    if args.clean:
        n0, m0 = len(V), len(F)
        V, F, vmap = clean_mesh(V, F)
        print(f"cleaned mesh: {n0:,} -> {len(V):,} vertices, {len(F):,} faces")
        if barriers is not None:
            options = options.replace(barriers=renumber(barriers, vmap, faces_kept=len(F) == m0))
        if S.snap_distance is None:
            new = vmap[S.idx]
            if (new < 0).any():
                raise SampleError(
                    f"{int((new < 0).sum())} samples sit on vertices that --clean removed (e.g. vertex "
                    f"{int(S.idx[new < 0][0])}, used by no face); sample vertices of the surface only")
            S = Samples.from_indices(new, S.vals, len(V), names=S.names, duplicates=args.duplicates)
        else:
            S = read_samples(args.samples, V, **read)
    return (V, F, S) if options is None else (V, F, S, options)


def write_surface(out, V, F, point_data):
    """Write named fields (and manifill's masks) to a mesh file, saying what the format renamed or hides."""

    written = write_mesh(out, V, F, point_data)
    renamed = {a: b for a, b in written.items() if a != b}
    if renamed:
        print("note: fields renamed for the format: " + ", ".join(f"{a!r} -> {b!r}" for a, b in renamed.items()))
    note = format_note(out)
    if note:
        print(note)


def levels(text):
    """``--levels``: a count, or comma-separated explicit levels (a list of floats)."""
    if text is None:
        return None
    try:
        if "," in text:
            return [float(t) for t in text.split(",") if t.strip()]
        return int(text)
    except ValueError:
        raise SampleError(f"--levels {text!r} is neither a count nor a comma-separated list of numbers") from None


def bounds_arg(text):
    """``--bounds``: ``samples`` or ``LO,HI`` (either side may be empty: open)."""
    if text is None or text == "samples":
        return text
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return tuple(float(x) if x.strip() else None for x in parts)
    except ValueError:
        raise OptionError(f"--bounds {text!r} is neither 'samples' nor LO,HI (e.g. --bounds 0,1)") from None


def smoothing_arg(text):
    """``--smoothing``: a number >= 0 or ``auto``."""
    if text is None or text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise OptionError(f"--smoothing {text!r} is neither a number nor 'auto' (e.g. --smoothing auto)") from None


def step_bar(args, steps):
    """The progress bar of a command over the ``steps`` it runs (nothing with --quiet).

    Parameters
    ----------
    args : argparse.Namespace
    steps : sequence of str
        The names of the steps the run will tell the bar, in order: the bar's total.
    """

    return progress.StepBar(len(steps), enabled=not getattr(args, "quiet", False), desc=f"manifill {args.command}")


def print_time(args, seconds):
    """The total time, and with --verbose every step's."""
    if getattr(args, "verbose", False):
        print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in seconds.items()))
    else:
        print(f"time: {seconds.get('total', sum(seconds.values())):.2f} s (--verbose: per step)")


def chosen_field(args, names):
    """The field ``--field`` names (the first by default), checked before the work.

    ``names`` are the value fields; ``--field`` may also name what the run adds (:func:`std_names`:
    ``<field>_std``, ``trusted``; with --gradient, ``grad_<field>_norm``).
    """
    name = getattr(args, "field", None)
    if name is None:
        return names[0]
    choices = list(names) + [n for n in std_names(args, names) if n not in names]
    choices += [f"grad_{n}_norm" for n in names] if getattr(args, "gradient", False) else []
    if name not in choices:
        raise OptionError(f"--field {name!r} is not one of the fields ({', '.join(choices)}); pick one of them")
    return name


def pictures(args, V, F, X, names, samples=None, curves=None, title=None, extra=None):
    """--render PNG and --html viewer (every field, --field shown first) of a surface result.

    ``extra``: the point fields the run adds (``<field>_std``, ``trusted``). The PNG shows the --field,
    and when it is a value field with a std, the std beside it (and ``trusted`` with --trust), each
    on its own colour bar.
    """
    field = chosen_field(args, names)
    fields = {name: X[:, j] for j, name in enumerate(names)}
    fields.update(extra or {})
    if getattr(args, "render", None):

        show = [field] + ([k for k in (f"{field}_std", "trusted") if k in fields] if field in names else [])
        render_fields(V, F, {k: fields[k] for k in show}, args.render, show=show, samples=samples, curves=curves,
                      title=title)
        print(f"rendered {args.render} ({', '.join(show)})")
    if getattr(args, "html", None):

        write_html(args.html, V, F, fields, field=field, samples=samples, curves=curves,
                   title=title or "manifill")
        print(f"wrote the viewer {args.html}")


def err(msg):
    """Print the one-line error and give exit status 2."""
    print(f"manifill: error: {msg}", file=sys.stderr)
    return 2


def surface_outputs(args, pictures=True, extra=()):
    """-o (and --render/--html) of a surface command, checked before any work (``extra``: more -o suffixes)."""

    meshes = tuple(e for e, f in MESH_FORMATS.items() if f.write and f.fields)
    outs = [("-o", args.output, (*meshes, *VALUE_FORMATS, *extra))]
    if pictures:
        outs += [("--render", getattr(args, "render", None), (".png",)),
                 ("--html", getattr(args, "html", None), (".html",))]
    return check_outputs(outs, [args.mesh, args.samples])[0]


def check_names(args, S, out):
    """The field names against the output's format and manifill's masks, and --field, before the work."""

    check_field_names(S.names, out)
    added = [name for name in std_names(args, S.names) + gradient_names(args, S.names, out)
             if name in S.names]
    if added:
        raise WriteError(f"field name {added[0]!r} is also the name of a field this run adds (a std, a draw, a "
                         f"gradient); rename the value column")
    chosen_field(args, S.names)


def print_ranges(X, S, out):
    """Each field's range beside the samples' (overshoot shows), and the output path."""

    (lo, hi), (slo, shi) = value_ranges(X), value_ranges(S.vals)
    shown = range(len(S.names)) if len(S.names) <= MANY_FIELDS else range(3)
    for j in shown:
        print(f"  {S.names[j]}: range [{lo[j]:.6g}, {hi[j]:.6g}]  (samples [{slo[j]:.6g}, {shi[j]:.6g}])")
    if len(S.names) > MANY_FIELDS:
        print(f"  ... {len(S.names) - 3} more fields; all {len(S.names)}: range [{min(lo):.6g}, {max(hi):.6g}]  "
              f"(samples [{min(slo):.6g}, {max(shi):.6g}])")
    print(f"wrote {out}")


#: beyond this many fields, the command line names a few and sums up the rest
MANY_FIELDS = 8


def field_list(names):
    """The fields' names for a line: all of them, or the first three and the last of many."""
    names = list(names)
    if len(names) <= MANY_FIELDS:
        return ", ".join(names)
    return f"{', '.join(names[:3])}, ..., {names[-1]}"


#: the methods with a probability model (a standard deviation): --uncertainty and --trust take only these
def std_methods():
    """The methods that give a std, the Gaussian process first (``gp, harmonic, biharmonic or triharmonic``)."""
    have = [name for name in METHODS if method_of(name).gives_std]
    return sorted(have, key=lambda name: not method_of(name).gp_mean)


_GP_FLAGS = (("gp_alpha", "--gp-alpha"), ("gp_range", "--gp-range"), ("gp_sigma", "--gp-sigma"), ("noise", "--noise"),
             ("variance", "--variance"), ("variance_samples", "--variance-samples"))


def _variance_opts(args, gp):
    """``gp`` with ``variance`` and ``samples`` from --variance and --variance-samples, checked."""
    if args.variance is not None:
        gp["variance"] = args.variance
    if args.variance_samples is not None:
        if args.variance == "exact":
            raise OptionError("--variance-samples is the Monte Carlo count of --variance sampled (or auto), "
                              "not of --variance exact; leave one out")
        if args.variance_samples < 2:
            raise OptionError(f"--variance-samples {args.variance_samples} is below 2; pass e.g. "
                              f"--variance-samples 100")
        gp["samples"] = args.variance_samples
    return gp


def _auto_or_number(text, flag, zero=False):
    """``X|auto`` of a gp option: 'auto' or a finite number > 0 (>= 0 with ``zero``)."""
    if text == "auto":
        return text
    try:
        x = float(text)
    except ValueError:
        x = float("nan")
    if not (x == x and abs(x) != float("inf") and (x > 0 or (zero and x == 0))):
        raise OptionError(f"{flag} {text!r} is not a number {'>=' if zero else '>'} 0 or 'auto'; pass e.g. "
                          f"{flag} {'0' if zero else '0.5'} or {flag} auto")
    return x


def wants_std(args):
    """Whether the run computes a standard deviation (--method gp, --uncertainty or --trust)."""
    method = getattr(args, "method", None)
    return (method is not None and method_of(method).gp_mean) or getattr(args, "uncertainty", False) \
        or getattr(args, "trust", None) is not None


def uncertainty_opts(args, *, in_solid=False):
    """The keywords of ``--method gp``, ``--uncertainty``, ``--trust`` and ``--untrusted`` for the library.

    Every combination the library would refuse is refused here first, naming the flags, before
    anything is read. ``in_solid``: only the Gaussian process gives a std there (the fill of the
    inside is not a model).

    Returns
    -------
    dict
        ``gp`` (the options of :class:`manifill.GPOptions` given on the command line), ``uncertainty``,
        ``trust``, ``untrusted``: only those that apply.

    Raises
    ------
    OptionError
        A gp option without --method gp, --uncertainty or --trust with a method that has no standard
        deviation, --untrusted without --trust, a bad number.
    """
    m = method_of(args.method)
    named = args.method or f"the default method ({m.name})"
    asks = args.uncertainty or args.trust is not None
    model = m.gp_mean or (m.gives_std and not in_solid)
    given = [flag for key, flag in _GP_FLAGS if getattr(args, key, None) is not None]
    energy_std = model and not m.gp_mean and asks
    if energy_std:  # an energy method's std: how its variance is computed may be given
        given = [flag for flag in given if flag not in ("--variance", "--variance-samples")]
    if given and not m.gp_mean:
        hint = " (the energy methods take noisy samples with --smoothing)" if given[0] == "--noise" else ""
        if given[0] in ("--variance", "--variance-samples") and m.gives_std:
            raise OptionError(f"{given[0]} says how --uncertainty computes the std; pass --uncertainty too, or "
                              f"leave {given[0]} out")
        raise OptionError(f"{given[0]} is an option of --method gp, not of {named}; pass --method gp or leave "
                          f"{given[0]} out{hint}")
    if asks and not model:
        flag = "--uncertainty" if args.uncertainty else "--trust"
        # the pipeline and the gradually varied fit: values committed on curves or levels, no model behind them
        why = " (its curve values are estimates, not a model)" if not (m.can_smooth or m.delegates) else ""
        with_std = [name for name in std_methods() if not in_solid or method_of(name).gp_mean]
        if in_solid:
            why = " in a solid (the harmonic fill of the inside is not a model)"
        which = with_std[0] if len(with_std) == 1 else f"{', '.join(with_std[:-1])} or {with_std[-1]}"
        raise OptionError(f"{flag} needs a probability model, and {named} has none{why}; pass --method {which}")
    if m.gp_mean:
        for key, flag, fix in (("bounds", "--bounds", "leave it out"),
                               ("smoothing", "--smoothing", "give the samples' noise as --noise X or --noise auto")):
            if getattr(args, key, None) is not None:
                raise OptionError(f"{flag} does not apply to --method gp (a Gaussian posterior mean); {fix}")
        if getattr(args, "weights", None) not in (None, "cotan"):
            raise OptionError(f"--method gp uses the finite-element (cotan) stiffness, not --weights {args.weights}; "
                              f"leave --weights out")
        if getattr(args, "solver", None) == "iterate":
            raise OptionError("--method gp solves with --solver direct or amg (or auto), not iterate; pick one of "
                              "those")
    elif asks:
        if getattr(args, "bounds", None) is not None:
            raise OptionError("--uncertainty (or --trust) and --bounds together are not supported: a bounded fill "
                              "is not a Gaussian posterior mean; leave one out")
    if args.untrusted is not None and args.trust is None:
        raise OptionError("--untrusted says what --trust does where the std is too large; pass --trust T too, or "
                          "leave --untrusted out")
    if args.trust is not None and not (args.trust > 0 and args.trust != float("inf")):
        raise OptionError(f"--trust {args.trust:g} is not a number > 0 (a multiple of the samples' standard "
                          f"deviation); pass e.g. --trust 1")
    out = {}
    if energy_std and (args.variance is not None or args.variance_samples is not None):
        out["gp"] = _variance_opts(args, {})
    if m.gp_mean:
        gp = {}
        for key, flag, name, zero in (("gp_range", "--gp-range", "range", False),
                                      ("gp_sigma", "--gp-sigma", "sigma", False), ("noise", "--noise", "noise", True)):
            if getattr(args, key) is not None:
                gp[name] = _auto_or_number(getattr(args, key), flag, zero)
        if args.gp_alpha is not None:
            gp["alpha"] = args.gp_alpha
        if args.gp_alpha == 1 and not isinstance(gp.get("sigma", "auto"), str):
            raise OptionError("--gp-sigma needs --gp-alpha 2: the field of alpha 1 has no finite prior standard "
                              "deviation; leave --gp-sigma out")
        out["gp"] = _variance_opts(args, gp) or None
    if args.uncertainty:
        out["uncertainty"] = True
    if args.trust is not None:
        out["trust"] = args.trust
    if args.untrusted is not None:
        out["untrusted"] = args.untrusted
    return out


def check_draws(args, method):
    """--draws: a count of 1 or more, with a method that has a fitted probability model (--method gp)."""
    if not getattr(args, "draws", 0):
        return
    if args.draws < 0:
        raise OptionError(f"--draws {args.draws}: pass a count of 1 or more")
    if not method_of(method).gp_mean:
        which = f"--method {method}" if method else "the default method"
        raise OptionError(f"--draws takes whole fields from a fitted posterior, which {which} has not; add "
                          f"--method gp")


def add_draws(args, r, names, data):
    """--draws N: ``<name>_draw1 .. N`` into the point data ``data`` (the library's draws, seed 0)."""
    if not getattr(args, "draws", 0):
        return
    D = r.sample(args.draws, seed=0)
    if len(names) == 1 and D.ndim == r.values.ndim + 1:  # one field: its axis put back
        D = D[..., None, :]
    data.update({f"{name}_draw{i + 1}": D[..., j, i] for j, name in enumerate(names) for i in range(args.draws)})


def vector_output(path):
    """Whether the output ``path`` holds a vector per point (the gradient as one array, ``Format.vectors``);
    others get one column per component."""
    return getattr(written_as(path, ("mesh", "grid", "tets")), "vectors", False)


def gradient_names(args, names, path):
    """The point fields --gradient adds for ``names`` in the output ``path``."""
    if not getattr(args, "gradient", False):
        return []
    parts = [""] if vector_output(path) else ["_x", "_y", "_z"]
    return [f"grad_{name}{p}" for name in names for p in parts + ["_norm"]]


def std_names(args, names):
    """The point fields a run adds to ``names``: ``<name>_std`` for each (with a std), ``<name>_draw<i>``
    (--draws) and ``trusted`` (--trust)."""

    extra = [f"{name}_std" for name in names] if wants_std(args) else []
    extra += [f"{name}_draw{i + 1}" for name in names for i in range(max(getattr(args, "draws", 0) or 0, 0))]
    return extra + ([TRUSTED] if getattr(args, "trust", None) is not None else [])


def print_uncertainty(report, std, trusted, point_ndim=1):
    """The summary lines of the std (--method gp, --uncertainty) and of --trust."""

    for line in uncertainty_lines(report, std, trusted, point_ndim):
        print(line)
