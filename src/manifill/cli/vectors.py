"""``manifill reconstruct MESH ARROWS -o OUT``: a tangent vector field, when the samples are arrows.

A sample file whose value columns are ``vx, vy, vz`` (:func:`manifill.io.vector_files.holds_vectors`) makes
``reconstruct`` run :func:`manifill.vectors.reconstruct.reconstruct_vectors` instead of the scalar methods: the
flags ``--symmetry``, ``--fit`` and ``--normal`` (:class:`manifill.vectors.options.VectorOptions`' table), the
methods ``biharmonic`` (the default), ``harmonic`` and ``gp`` (with ``--gp-range``, ``--gp-sigma``, ``--noise``,
``--variance``), ``--bounds`` (``samples``, a largest magnitude, or ``none``), ``--smoothing``, ``--solver``,
``--barriers``, ``--clean``, ``--render`` (the magnitude with arrows) and ``--html``. A flag only a scalar field
can use is refused in one line, before anything is read.
"""

import numbers
from dataclasses import replace
from pathlib import Path

from ..errors import OptionError, SampleError, WriteError
from ..io import format_note, read_mesh_file
from ..io.formats import find_format, suffix_of
from ..io.vector_files import read_vector_samples, vector_suffixes
from ..mesh.clean import clean_mesh
from ..surface.barriers import renumber
from ..vectors.options import VECTOR_METHODS
from ..vectors.reconstruct import reconstruct_vectors
from ..viz.arrows import vector_field
from ..viz.render import render_vectors
from ..viz.viewer import write_vectors_html
from .common import barriers_arg, check_barrier_numbering, check_order, print_time, smoothing_arg
from .options import OPTION_FLAGS, choices_of, default_of

__all__ = ["vector_args", "refuse_vector_flags", "run_vectors"]

#: The flags of arrows alone: (attribute, flag).
VECTOR_ONLY = (("symmetry", "--symmetry"), ("fit", "--fit"), ("normal", "--normal"))
#: The flags of ``reconstruct`` a vector field cannot use: (attribute, flag).
SCALAR_ONLY = (("weights", "--weights"), ("on_empty", "--on-empty"), ("partition", "--partition"),
               ("curve_values", "--curve-values"), ("distance", "--distance"), ("levels", "--levels"),
               ("neighbours", "--neighbours"), ("bounds_mode", "--bounds-mode"), ("uncertainty", "--uncertainty"),
               ("gp_alpha", "--gp-alpha"), ("variance_samples", "--variance-samples"), ("draws", "--draws"),
               ("trust", "--trust"), ("untrusted", "--untrusted"), ("gradient", "--gradient"),
               ("subdivide", "--subdivide"), ("check", "--check"), ("chunk", "--chunk"), ("workers", "--workers"),
               ("scheduler", "--scheduler"))
#: The options of ``--method gp`` for arrows: (attribute, flag).
GP_FLAGS = (("gp_range", "--gp-range"), ("gp_sigma", "--gp-sigma"), ("noise", "--noise"), ("variance", "--variance"))
SYMMETRY_WORDS = {1: "arrows", 2: "lines (no sign)", 4: "crosses"}


def vector_args(s):
    """--symmetry, --fit and --normal: the options of arrows (samples with columns vx, vy, vz)."""
    g = s.add_argument_group("vector fields (samples with the columns vx, vy, vz: a tangent field of arrows)")
    g.add_argument("--symmetry", type=int, choices=choices_of("vectors.symmetry"), default=None,
                   help="1: arrows (default); 2: lines, a sample the same as its opposite (fibres, hatching); "
                        "4: crosses")
    g.add_argument("--fit", choices=choices_of("vectors.fit"), default=None,
                   help="fit a potential's gradient (curl-free) or a stream function's rotated gradient "
                        "(divergence-free: an incompressible flow) to the arrows")
    g.add_argument("--normal", choices=choices_of("vectors.normal"), default=None,
                   help="an arrow more than a tenth normal to the surface: refuse (default) or drop its normal part")


def refuse_vector_flags(args):
    """A scalar run refuses the flags of arrows, in one line."""
    for key, flag in VECTOR_ONLY:
        if getattr(args, key, None) is not None:
            raise OptionError(f"{flag} is an option of arrows (samples with the columns vx, vy, vz), and "
                              f"{Path(args.samples).name} holds values; leave {flag} out")


def _given(args, key, flag):
    value = getattr(args, key, None)
    if flag in OPTION_FLAGS:
        return value is not None and value != default_of(OPTION_FLAGS[flag])
    return bool(value)


def _bounds(text):
    """``--bounds`` of arrows: None or 'samples' (the samples' largest magnitude), 'none', or a magnitude > 0."""
    if text is None or text == "samples":
        return True
    if text.strip().lower() == "none":
        return False
    try:
        top = float(text)
    except ValueError:
        top = float("nan")
    if not (top > 0 and top != float("inf")):
        raise OptionError(f"--bounds {text!r}: arrows take 'samples' (no magnitude above the samples' largest, the "
                          f"default), a largest magnitude (e.g. --bounds 2.5) or 'none'")
    return top


def _gp(args, method):
    """The ``gp`` options of ``--method gp`` (None for the others, which refuse them)."""
    given = [(key, flag) for key, flag in GP_FLAGS if getattr(args, key, None) is not None]
    if not VECTOR_METHODS[method].gives_std:
        if given:
            raise OptionError(f"{given[0][1]} is an option of --method gp, not of {method}; pass --method gp or "
                              f"leave {given[0][1]} out")
        return None
    gp = {}
    for key, flag, name in (("gp_range", "--gp-range", "range"), ("gp_sigma", "--gp-sigma", "sigma")):
        text = getattr(args, key, None)
        if text is not None and text != "auto":
            gp[name] = _positive(text, flag)
    if args.noise is not None:  # the command line's noise is a standard deviation; the vector gp's a variance
        if args.noise == "auto":
            raise OptionError("--noise auto is not fitted for arrows; pass the noise's standard deviation (e.g. "
                              "--noise 0.1) or leave it out (exact arrows)")
        gp["noise"] = _positive(args.noise, "--noise", zero=True) ** 2
    if args.variance is not None:
        gp["variance"] = args.variance
    return gp or None


def _positive(text, flag, zero=False):
    try:
        x = float(text)
    except ValueError:
        x = float("nan")
    if not (x == x and x != float("inf") and (x > 0 or (zero and x == 0))):
        raise OptionError(f"{flag} {text!r} is not a number {'>=' if zero else '>'} 0 or 'auto'; pass e.g. "
                          f"{flag} {'0' if zero else '0.5'}")
    return x


def _options(args):
    """The keywords of :func:`manifill.vectors.reconstruct.reconstruct_vectors` from the flags, each checked."""
    for key, flag in SCALAR_ONLY:
        if _given(args, key, flag):
            raise OptionError(f"{flag} is an option of scalar fields, and {Path(args.samples).name} holds arrows "
                              f"(vx, vy, vz); leave {flag} out")
    method = args.method or "biharmonic"
    if method not in VECTOR_METHODS:
        raise OptionError(f"--method {method} is a method of scalar fields; arrows take --method "
                          f"{', '.join(VECTOR_METHODS)}")
    kw = {"method": method, "bounds": _bounds(args.bounds), "solver": args.solver}
    for key in ("symmetry", "fit", "normal", "max_distance"):
        if getattr(args, key, None) is not None:
            kw[key] = getattr(args, key)
    if args.smoothing is not None:
        kw["smoothing"] = smoothing_arg(args.smoothing)
    gp = _gp(args, method)
    if gp is not None:
        kw["gp"] = gp
    return kw


def _load(args):
    """The mesh (cleaned with --clean), the arrows and the barriers, in the mesh's numbering."""
    check_order(args.mesh, args.samples)
    mesh = read_mesh_file(args.mesh, points=True)
    if mesh.F is None:
        raise OptionError(f"{Path(args.mesh).name} is a point cloud (no faces), and a vector field needs triangles; "
                          f"mesh it first")
    barriers = barriers_arg(args)
    check_barrier_numbering(mesh, barriers)
    arrows = read_vector_samples(args.samples, mesh.V, duplicates=args.duplicates, max_distance=args.max_distance,
                                 vertex_numbering=mesh.vertex_numbering)
    V, F = mesh.V, mesh.F
    if args.clean:
        n0, m0 = len(V), len(F)
        V, F, vmap = clean_mesh(V, F)
        print(f"cleaned mesh: {n0:,} -> {len(V):,} vertices, {len(F):,} faces")
        if barriers is not None:
            barriers = renumber(barriers, vmap, faces_kept=len(F) == m0)
        if arrows.where.ndim == 1:  # vertex numbers: the cleaned mesh's
            new = vmap[arrows.where]
            if (new < 0).any():
                raise SampleError(f"{int((new < 0).sum())} arrows sit on vertices that --clean removed (e.g. vertex "
                                  f"{int(arrows.where[new < 0][0])}, used by no face); sample vertices of the surface")
            arrows = replace(arrows, where=new)
    return V, F, arrows, barriers


def _check_outputs(args, out):
    if suffix_of(out) not in vector_suffixes():
        raise WriteError(f"{out.name}: a vector field is written as {', '.join(vector_suffixes())}; change the name "
                         f"(-o)")


def run_vectors(args, out):
    """Reconstruct the tangent field of the arrows in ``args.samples``, write it, render it, say what ran."""
    kw = _options(args)
    _check_outputs(args, out)
    vector_field(["v"], args.field, VECTOR_METHODS[kw["method"]].gives_std)  # --field, before the work
    V, F, arrows, barriers = _load(args)
    r = reconstruct_vectors(V, F, arrows.where, arrows.vectors, names=[arrows.name], barriers=barriers, **kw)
    r.save(out)
    _summary(r, V, arrows)
    print_time(args, r.report["seconds"])
    mag = r.magnitude if r.magnitude.ndim == 1 else r.magnitude[:, 0]
    given = arrows.magnitudes
    print(f"  {arrows.name}: magnitude [{mag.min():.6g}, {mag.max():.6g}]  (arrows [{given.min():.6g}, "
          f"{given.max():.6g}])")
    note = format_note(out)
    if note:
        print(note)
    mesh = find_format("mesh", out, writing=True)
    if mesh is not None and not mesh.cell_fields:
        print(f"note: {out.name}: {mesh.name} holds no per-face fields, so the face vectors are not written (.vtu, "
              f".vtp and .vtk hold them)")
    print(f"wrote {out}")
    title = f"{r.report['method']}, {SYMMETRY_WORDS[r.symmetry]}"
    if getattr(args, "render", None):
        render_vectors(r, args.render, field=args.field, title=title)
        shown = vector_field(r.field_names, args.field, r.std is not None)[1]
        print(f"rendered {args.render} ({shown} with arrows)")
    if getattr(args, "html", None):
        write_vectors_html(args.html, r, field=args.field, title=title)
        print(f"wrote the viewer {args.html}")
    return 0


def _summary(r, V, arrows):
    """The lines that say what ran: the arrows, the method, the bounds, the singularities."""
    rep, S = r.report, arrows.samples
    print(f"{len(V):,} vertices, {len(arrows.vectors):,} arrows ({arrows.name}: vx, vy, vz): a tangent vector field "
          f"of {SYMMETRY_WORDS[r.symmetry]}")
    if arrows.where.ndim == 2:
        inside = rep.get("inside_faces")
        print("arrows at positions, located on the surface" + (f": {inside:,} inside faces" if inside else "")
              + (f"; largest distance to a vertex {S.snap_distance.max():.3g}" if S.snap_distance is not None else ""))
    if VECTOR_METHODS[rep["method"]].gives_std:
        how = f"{rep['method']}, the Matérn field of the connection Laplacian (a mean and a std)"
    else:
        how = f"the {rep['method']} energy of the connection, {'smoothed' if rep.get('smoothing') else 'exact'} at " \
              f"the arrows"
    if rep.get("fit"):
        how += f", fitted {rep['fit']} ({'a potential' if rep['fit'] == 'curl-free' else 'a stream function'})"
    print(f"vector field: {how}")
    if "range" in rep:  # the gp's prior: fitted by likelihood, or given
        fitted = rep.get("fitted") or ()
        sigma = rep.get("sigma", float("nan"))
        sigma = sigma[0] if hasattr(sigma, "__len__") else sigma  # one per field: the first's
        print(f"gp: range {rep['range']:.4g} ({'fitted' if 'range' in fitted else 'given'}), sigma {sigma:.4g} "
              f"({'fitted' if 'sigma' in fitted else 'given'}); the std is per tangent component")
    if rep.get("smoothing"):
        lam = rep["smoothing"].get("lambda")
        print(f"smoothing: lambda {float(lam if not hasattr(lam, '__len__') else lam[0]):.3g}")
    cut = rep.get("barriers")
    if cut:
        print("barriers: " + ", ".join(f"{v:,} {k.replace('_', ' ')}" for k, v in cut.items()
                                       if isinstance(v, numbers.Integral)))
    b = rep.get("bounds")
    if b:
        print(f"bounds: magnitudes at most {b['magnitude']:.4g}; {b['vertices_scaled']:,} vertices brought down to it")
    sing = r.singularities[0] if r.singularities else None
    if sing is not None:
        total = float(sing["index"].sum())
        print(f"singularities: {sing['faces'].size} (indices sum to {total:g})")
