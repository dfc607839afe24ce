"""``manifill globe STATIONS -o OUT.nc``: stations by longitude and latitude to a CF netCDF on a regular grid; a
wind (columns ``u``, ``v``: eastward and northward) as a tangent vector field, written as ``eastward_wind`` and
``northward_wind`` (:mod:`manifill.adapters.globe_vectors`)."""

from ..adapters.globe import globe_file
from ..adapters.globe_vectors import globe_vectors_file, holds_components
from .common import smoothing_arg
from .options import output_args

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill globe``."""
    s = sub.add_parser("globe", help="stations by lon/lat to a CF netCDF on a regular lon/lat grid",
                       description="Reconstruct a field on the sphere from stations given by longitude and latitude "
                                   "(a CSV with lon, lat and value columns, or a netCDF with a station dimension and "
                                   "optionally time), with distances along the sphere, and write it on a regular "
                                   "grid as a CF-annotated netCDF (needs the [xarray] extra).")
    s.add_argument("stations", help="a CSV (lon, lat, value columns) or a netCDF of stations")
    s.add_argument("--var", default=None, help="the variable (netCDF) or value column (CSV); default: all")
    s.add_argument("--lon", default="lon", help="the longitude column or variable, degrees (default: lon)")
    s.add_argument("--lat", default="lat", help="the latitude column or variable, degrees (default: lat)")
    s.add_argument("--grid", type=float, default=1.0, help="the grid's spacing in degrees (default: 1)")
    s.add_argument("--method", default=None, help="any reconstruct method (default: manifill's default, the "
                                                  "biharmonic fill kept within the stations' range)")
    s.add_argument("--smoothing", default=None, help="a number or 'auto' (noisy stations)")
    s.add_argument("--east", default="u", help="the eastward component's column or variable: with --north, the "
                                               "stations hold a vector field (default: u)")
    s.add_argument("--north", default="v", help="the northward component's column or variable (default: v); "
                                                "without --var, stations with both are reconstructed as a tangent "
                                                "vector field, written as eastward_<name> and northward_<name>")
    s.add_argument("--name", default=None, help="the vector field's name in the netCDF (default: wind for u, v)")
    s.add_argument("-o", "--output", required=True, metavar="OUT.nc", help="the netCDF to write")
    output_args(s)
    s.set_defaults(func=run)


def run(args):
    """Write the netCDF and say what it holds."""
    options = {} if args.smoothing is None else {"smoothing": smoothing_arg(args.smoothing)}
    if args.var is None and holds_components(args.stations, args.east, args.north):
        print(globe_vectors_file(args.stations, args.output, east=args.east, north=args.north, name=args.name,
                                 grid=args.grid, method=args.method, lon=args.lon, lat=args.lat,
                                 command=args.command_line, **options))
        return 0
    print(globe_file(args.stations, args.output, var=args.var, grid=args.grid, method=args.method, lon=args.lon,
                     lat=args.lat, command=args.command_line, **options))
    return 0
