"""The options several subcommands share, defined once."""

import argparse
import sys

from ..linalg.gp import GPOptions
from ..surface.options import CONSTRAINTS, GROUPS
from ..surface.methods.registry import method_of, names
from ..validate.constraints import choices
from ..vectors.options import VectorOptions

__all__ = ["MESH_HELP", "sample_args", "fill_args", "picture_args", "output_args", "pipeline_args", "uncertainty_args",
           "gradient_args", "check_workers", "max_distance_arg", "RENAMED_FLAGS", "OPTION_FLAGS", "forms_of",
           "choices_of", "default_of"]

#: Every flag that sets one option of the library, and that option (``gp.`` for :class:`manifill.GPOptions`',
#: ``vectors.`` for :class:`manifill.vectors.options.VectorOptions`'):
#: its choices and default come from the option's constraints table, and a test tries a wrong value for each.
OPTION_FLAGS = {
    "--duplicates": "duplicates", "--max-distance": "max_distance", "--weights": "weights", "--solver": "solver",
    "--on-empty": "on_empty", "--bounds": "bounds", "--bounds-mode": "bounds_mode", "--smoothing": "smoothing",
    "--partition": "partition", "--curve-values": "curve_values", "--distance": "distance", "--levels": "levels",
    "--neighbours": "neighbours", "--barriers": "barriers", "--trust": "trust", "--untrusted": "untrusted",
    "--gp-alpha": "gp.alpha", "--gp-range": "gp.range", "--gp-sigma": "gp.sigma", "--noise": "gp.noise",
    "--variance": "gp.variance", "--variance-samples": "gp.samples",
    "--symmetry": "vectors.symmetry", "--fit": "vectors.fit", "--normal": "vectors.normal",
}


def forms_of(name):
    """The constraints of one option, by its flat keyword, ``gp.<name>`` or ``vectors.<name>``."""
    if name.startswith("gp."):
        return GPOptions.CONSTRAINTS[name[3:]]
    if name.startswith("vectors."):
        return VectorOptions.CONSTRAINTS[name[8:]]
    return CONSTRAINTS[name]


def choices_of(name):
    """The closed set of one option (for ``choices=``)."""
    return choices(forms_of(name))


def default_of(name):
    """The library's default of one option (its group's)."""
    if name.startswith("gp."):
        return GPOptions.__dataclass_fields__[name[3:]].default
    if name.startswith("vectors."):
        return VectorOptions.__dataclass_fields__[name[8:]].default
    group = next(cls for cls in GROUPS.values() if name in cls.CONSTRAINTS)
    return group.__dataclass_fields__[name].default

MESH_HELP = ".vtu .vtp .vtk .ply .off .obj .stl .surf.gii, or a FreeSurfer surface such as lh.pial"


def sample_args(s):
    """MESH SAMPLES and the options of reading them, shared by the subcommands."""
    s.add_argument("mesh", help=f"mesh file ({MESH_HELP})")
    s.add_argument("samples", help="samples: .csv with header vertex,value[,...] or x,y,z,value[,...]; .npz; .npy; "
                                   "per-vertex data with NaN where unmeasured (.func.gii, .shape.gii, .mgh, "
                                   "FreeSurfer lh.thickness ...); FreeSurfer .label")
    s.add_argument("--duplicates", choices=choices_of("duplicates"), default=default_of("duplicates"),
                   help="two samples on one vertex with different values: error (default) or average")
    max_distance_arg(s, help="largest accepted distance from a sample position to its vertex (to the surface for the "
                             "energy methods, which constrain the positions exactly) (default: 5%% of the mesh's "
                             "bounding-box diagonal plus its vertex spacing)")
    s.add_argument("--clean", action="store_true",
                   help="weld coinciding vertices and drop unused vertices and zero-area faces first")


def fill_args(s):
    """-o OUT and the options of the harmonic fill, shared by harmonic and reconstruct."""
    s.add_argument("-o", "--output", required=True,
                   help="output: .vtu/.vtp/.vtk/.ply (mesh with named fields) or .csv/.npy (values); for "
                        "reconstruct also a time series: .xdmf (with .h5), .pvd (with a folder of .vtu), .h5")
    s.add_argument("--weights", choices=choices_of("weights"), default=default_of("weights"),
                   help=f"Laplacian weights (default: {default_of('weights')})")
    s.add_argument("--solver", choices=choices_of("solver"), default=default_of("solver"),
                   help=f"linear solver (default: {default_of('solver')})")
    s.add_argument("--on-empty", choices=choices_of("on_empty"), default=default_of("on_empty"),
                   help="a component without samples: error (default) or fill with NaN")


def picture_args(s):
    """--render, --html and --field of a surface result."""
    s.add_argument("--render", default=None, metavar="OUT.png",
                   help="also render the result (field, samples, curves) as a PNG, off-screen (needs pyvista)")
    s.add_argument("--html", default=None, metavar="OUT.html",
                   help="also write an interactive viewer: one self-contained HTML file that opens offline, "
                        "with a menu of every field")
    s.add_argument("--field", default=None, metavar="NAME",
                   help="the field --render draws and --html shows first (default: the first value column)")


def output_args(s):
    """--quiet and --verbose."""
    g = s.add_mutually_exclusive_group()
    g.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors (no progress bar)")
    g.add_argument("-v", "--verbose", action="store_true", help="also print the time of every step")




def gradient_args(s):
    """--gradient: the fields' gradients beside them."""
    s.add_argument("--gradient", action="store_true",
                   help="also write each field's gradient per vertex (voxel), grad_<field> (a vector in VTK files; "
                        "grad_<field>_x, _y, _z in others), and its magnitude grad_<field>_norm")


def series_args(s):
    """--check, --chunk, --workers and --scheduler: many fields, and time series (an .xdmf, .pvd or .h5 output)."""
    s.add_argument("--check", action="store_true",
                   help="run Step 1 (the gradual variation report) for every field; by default it runs for up to "
                        "10 fields")
    s.add_argument("--chunk", type=int, default=None, metavar="T",
                   help="time series: reconstruct and write this many time steps at a time (default: by memory, "
                        "about 64 MB of values per chunk)")
    g = s.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, default=None, metavar="N",
                   help="time series: apply the chunks on N worker processes of this machine (a Dask LocalCluster, "
                        "one thread each; needs the [batch] extra); the same file as without")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="time series: apply the chunks on an existing Dask cluster (e.g. tcp://host:8786; its "
                        "workers need manifill); without --workers or --scheduler, the environment variable "
                        "DASK_SCHEDULER_ADDRESS, when set, is used")


def check_workers(args):
    """``--workers``, refused in one line naming the flag unless it is a number >= 1 (None when not given)."""
    from ..errors import OptionError

    if args.workers is not None and args.workers < 1:
        raise OptionError(f"--workers {args.workers}: pass a number of worker processes >= 1")
    return args.workers


def energy_args(s):
    """--bounds (every method but rbf) and --smoothing (the energy methods and rbf)."""
    s.add_argument("--bounds", default=None, metavar="samples|LO,HI",
                   help="keep the field within these bounds ('samples': each field's sample range), as "
                        "--bounds-mode says")
    s.add_argument("--bounds-mode", choices=choices_of("bounds_mode"), default=None,
                   help="exact (default with --bounds): the minimiser within the bounds, an active set (gvf-harmonic: "
                        "curve values projected onto them, then the bounded fill); project: the field without bounds, "
                        "then clipped onto them (one solve; any method)")
    s.add_argument("--smoothing", default=None, metavar="LAMBDA|auto",
                   help="energy methods and rbf: soft constraints with this lambda ('auto': generalised "
                        "cross-validation)")


def pipeline_args(s, *, method_help="default: the measured default, gvf-harmonic with monotone curve values and "
                                     "--bounds samples (pass --method gvf-harmonic for the paper's pipeline alone)"):
    """The options of the surface pipeline (Steps 1-6), shared by reconstruct and volume."""
    s.add_argument("--method", choices=names(), default=None,
                   help=f"{method_help}; " + "; ".join(f"{name}: {method_of(name).summary}" for name in names(False)))
    s.add_argument("--partition", choices=choices_of("partition"), default=default_of("partition"),
                   help=f"default: {default_of('partition')}")
    s.add_argument("--curve-values", choices=choices_of("curve_values"), default=None,
                   help="default: monotone for the default method, hermite for --method gvf-harmonic")
    s.add_argument("--distance", choices=choices_of("distance"), default=default_of("distance"),
                   help=f"default: {default_of('distance')}")
    s.add_argument("--levels", default=None, help="a count of uniform levels, or comma-separated levels")


def cloud_args(s):
    """--neighbours (how a point cloud is joined) and --barriers (lines the field must not cross)."""
    s.add_argument("--neighbours", type=int, default=None, metavar="K",
                   help="a point cloud's nearest neighbours per point, for its Laplacian and graph (default: 16)")
    s.add_argument("--barriers", default=None, metavar="FILE",
                   help="lines the field must not cross: a .txt with one path of vertex indices per line, a .csv of "
                        "x,y,z[,barrier] points snapped to vertices, or an .npy of per-face labels")


def uncertainty_args(s):
    """--uncertainty, --trust, --untrusted and the options of --method gp, shared by reconstruct and volume."""
    g = s.add_argument_group("uncertainty and --method gp (a Matérn Gaussian process)")
    g.add_argument("--uncertainty", action="store_true",
                   help="also write each field's posterior standard deviation as <field>_std (--method gp always "
                        "does; harmonic, biharmonic and triharmonic read as Gaussian fields)")
    g.add_argument("--gp-alpha", type=int, choices=choices_of("gp.alpha"), default=None,
                   help="gp: SPDE order, 2 (default: Matérn nu = 1 on a surface) or 1")
    g.add_argument("--gp-range", default=None, metavar="X|auto",
                   help="gp: distance at which the correlation falls to about 0.13, in mesh units (default: auto, "
                        "fitted by restricted likelihood)")
    g.add_argument("--gp-sigma", default=None, metavar="X|auto",
                   help="gp: prior standard deviation of the field (default: auto, fitted)")
    g.add_argument("--noise", default=None, metavar="X|auto",
                   help="gp: standard deviation of the measurement noise, in value units (default: 0, the samples "
                        "are interpolated; auto: fitted)")
    g.add_argument("--variance", choices=choices_of("gp.variance"), default=None,
                   help="gp: how the std is computed: exact (selected inversion of the sparse Cholesky factor), "
                        "sampled (Monte Carlo, with its error in the summary) or auto (default: exact with the "
                        "[cholmod] extra or up to 20,000 unknowns)")
    g.add_argument("--variance-samples", type=int, default=None, metavar="N",
                   help="gp: Monte Carlo samples of --variance sampled (default: 100; error about 1/sqrt(N))")
    g.add_argument("--draws", type=int, default=0, metavar="N",
                   help="--method gp: also write N draws of each field from its posterior, <field>_draw1 .. "
                        "<field>_drawN: whole fields through the samples, for carrying the uncertainty onwards")
    g.add_argument("--trust", type=float, default=None, metavar="T",
                   help="mark as untrusted (point field 'trusted' = 0) every vertex where a field's std exceeds T "
                        "times the standard deviation of its samples (implies --uncertainty)")
    g.add_argument("--untrusted", choices=choices_of("untrusted"), default=None,
                   help="what --trust does there: mask only (default) or also set the value NaN")


#: Options renamed, their old spelling taken for one release with a note: old -> the new one, as the note says it.
RENAMED_FLAGS = {"--max-snap": "--max-distance (the library's max_distance)"}


class _Renamed(argparse.Action):
    """An option under its new name, or under its old one (:data:`RENAMED_FLAGS`) with a one-line note."""

    def __call__(self, parser, namespace, values, option_string=None):
        if option_string in RENAMED_FLAGS:
            print(f"manifill: note: {option_string} is now {RENAMED_FLAGS[option_string]}; the old name goes in the "
                  f"next release", file=sys.stderr)
        setattr(namespace, self.dest, values)


def max_distance_arg(s, help):
    """``--max-distance`` (``max_distance`` of the library), also as ``--max-snap`` for one release."""
    s.add_argument("--max-distance", "--max-snap", dest="max_distance", type=float, default=None, action=_Renamed,
                   metavar="D", help=help)
