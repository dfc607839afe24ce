"""What the command line's subcommands share: reading the inputs, checking every output before the work, writing.

All outputs of one command (``-o``, ``--render``, ``--html``) are checked before
anything is read or computed: a known extension, an existing and writable folder,
no output equal to an input or to another output. Results are written with
manifill's mask arrays under their fixed names (:data:`manifill.io.SAMPLE_MASK`,
...), and a line says where a format hides the fields from a common reader. No numerics
here: masks come from the results (:meth:`manifill.results.Result.masks`), value ranges
from :func:`manifill.report.value_ranges`.
"""

import os
import sys
import tempfile
from pathlib import Path

from ..errors import OptionError, SampleError, WriteError

__all__ = ["load", "check_outputs", "write_surface", "levels", "bounds_arg", "smoothing_arg", "step_bar", "print_time",
           "pictures", "chosen_field", "surface_outputs", "check_names", "print_ranges", "err"]


def load(args, keep_points=False):
    """Read mesh and samples (checked against the mesh's vertex numbering), optionally cleaning the mesh first.

    ``keep_points``: samples given as positions keep them (``S.points``), for the
    energy methods, which locate them on the surface.

    Returns
    -------
    V, F : numpy arrays
    S : manifill.surface.samples.Samples
    """
    from ..io import read_mesh_file, read_samples
    from ..surface.samples import Samples
    from ..mesh.clean import clean_mesh

    mesh = read_mesh_file(args.mesh)
    V, F = mesh.V, mesh.F
    # vertex indices refer to the file's numbering, so samples are read against it
    read = dict(duplicates=args.duplicates, max_distance=args.max_snap, vertex_numbering=mesh.vertex_numbering,
                keep_points=keep_points)
    S = read_samples(args.samples, V, **read)
    if args.clean:
        n0 = len(V)
        V, F, vmap = clean_mesh(V, F)
        print(f"cleaned mesh: {n0:,} -> {len(V):,} vertices, {len(F):,} faces")
        if S.snap_distance is None:
            new = vmap[S.idx]
            if (new < 0).any():
                raise SampleError(
                    f"{int((new < 0).sum())} samples sit on vertices that --clean removed (e.g. vertex "
                    f"{int(S.idx[new < 0][0])}, used by no face); sample vertices of the surface only")
            S = Samples.from_indices(new, S.vals, len(V), names=S.names, duplicates=args.duplicates)
        else:
            S = read_samples(args.samples, V, **read)
    return V, F, S


def _same(a, b):
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _writable(folder):
    """Whether a file can be created in ``folder`` (tried, since permissions alone do not tell)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".manifill-probe-", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(probe)
    return True


def check_outputs(outputs, inputs):
    """Check every output of a command before any work.

    Parameters
    ----------
    outputs : list of (str, str or None, tuple of str)
        ``(option, path, allowed extensions)``; a None path is skipped.
    inputs : list of str
        Input paths no output may overwrite.

    Returns
    -------
    list of Path
        The outputs (None where not given), in order.

    Raises
    ------
    WriteError
        A wrong extension, a missing or read-only folder, an output equal to an
        input or to another output.
    """
    seen, result = [], []
    ins = [Path(p).resolve() for p in inputs if p]
    for option, path, allowed in outputs:
        if path is None:
            result.append(None)
            continue
        out = Path(path)
        if out.suffix.lower() not in allowed:
            raise WriteError(f"{out.name}: {option} writes {', '.join(allowed)}; change the name")
        if not out.parent.is_dir():
            raise WriteError(f"folder {out.parent} does not exist; create it first or choose another path for "
                             f"{option}")
        if out.is_dir():
            raise WriteError(f"{out} is a folder; give {option} a file name")
        resolved = out.resolve()
        for src in ins:
            if resolved == src or _same(out, src):
                raise WriteError(f"{option} {out.name} is also an input; write to another file")
        for other, opt in seen:
            if resolved == other:
                raise WriteError(f"{option} and {opt} both write {out.name}; give them different names")
        if not _writable(out.parent):
            raise WriteError(f"folder {out.parent} is not writable; choose another path for {option}")
        seen.append((resolved, option))
        result.append(out)
    return result


def write_surface(out, V, F, point_data):
    """Write named fields (and manifill's masks) to a mesh file, saying what the format renamed or hides."""
    from ..io import format_note, write_mesh

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
    from ..progress import StepBar

    return StepBar(len(steps), enabled=not getattr(args, "quiet", False), desc=f"manifill {args.command}")


def print_time(args, seconds):
    """The total time, and with --verbose every step's."""
    if getattr(args, "verbose", False):
        print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in seconds.items()))
    else:
        print(f"time: {seconds.get('total', sum(seconds.values())):.2f} s (--verbose: per step)")


def chosen_field(args, names):
    """The field ``--field`` names (the first by default), checked before the work."""
    name = getattr(args, "field", None)
    if name is None:
        return names[0]
    if name not in names:
        from ..errors import OptionError

        raise OptionError(f"--field {name!r} is not one of the fields ({', '.join(names)}); pick one of them")
    return name


def pictures(args, V, F, X, names, samples=None, curves=None, title=None):
    """--render PNG (the --field) and --html viewer (every field, --field shown first) of a surface result."""
    field = chosen_field(args, names)
    fields = {name: X[:, j] for j, name in enumerate(names)}
    if getattr(args, "render", None):
        from ..viz.render import render

        render(V, F, fields[field], args.render, samples=samples, curves=curves, title=title or field, name=field)
        print(f"rendered {args.render} ({field})")
    if getattr(args, "html", None):
        from ..viz.viewer import write_html

        write_html(args.html, V, F, fields, field=field, samples=samples, curves=curves,
                   title=title or "manifill")
        print(f"wrote the viewer {args.html}")


def err(msg):
    """Print the one-line error and give exit status 2."""
    print(f"manifill: error: {msg}", file=sys.stderr)
    return 2


def surface_outputs(args, pictures=True):
    """-o (and --render/--html) of a surface command, checked before any work."""
    from ..io import MESH_FORMATS, VALUE_FORMATS

    meshes = tuple(e for e, f in MESH_FORMATS.items() if f.write and f.fields)
    outs = [("-o", args.output, meshes + VALUE_FORMATS)]
    if pictures:
        outs += [("--render", getattr(args, "render", None), (".png",)),
                 ("--html", getattr(args, "html", None), (".html",))]
    return check_outputs(outs, [args.mesh, args.samples])[0]


def check_names(args, S, out):
    """The field names against the output's format and manifill's masks, and --field, before the work."""
    from ..io import check_field_names

    check_field_names(S.names, out)
    chosen_field(args, S.names)


def print_ranges(X, S, out):
    """Each field's range beside the samples' (overshoot shows), and the output path."""
    from ..report import value_ranges

    (lo, hi), (slo, shi) = value_ranges(X), value_ranges(S.vals)
    for j, name in enumerate(S.names):
        print(f"  {name}: range [{lo[j]:.6g}, {hi[j]:.6g}]  (samples [{slo[j]:.6g}, {shi[j]:.6g}])")
    print(f"wrote {out}")
