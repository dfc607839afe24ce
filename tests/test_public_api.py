"""The public API's one argument order: geometry, then samples, positional; every option keyword-only.

Walks ``manifill.__all__``: every function, every class's constructor (and its ``from_*``
constructors) may take positionally only the names of :data:`POSITIONAL`, and everything
after them must come after ``*``. Result records are built by manifill, not called, and
are left out (:data:`RECORDS`).
"""

import dataclasses
import inspect

import pytest

import manifill
from manifill.results import Result

#: The names a public entry point may take positionally: the data it works on, never an option.
POSITIONAL = {
    # geometry
    "V", "F", "T",  # vertices, triangles, tetrahedra: (V, F) a surface, (V, T) a solid
    "P",  # the points of a point cloud (Surface.from_points)
    "mask",  # a voxel solid (its spacing and origin are options: each defaults to the unit grid)
    "surface",  # a prepared manifill.Surface (reconstruct_surface, values_on_curves, fill_patches)
    "G",  # the graph of a surface (check_gradual, partition)
    "A", "L",  # an energy matrix (QuadraticSolver, min_quad_with_fixed), a Laplacian (from_laplacian)
    # samples
    "idx", "vals",  # sample vertices (or positions) and their values
    "vectors",  # the arrows at the samples (reconstruct_vectors)
    "voxels",  # sample voxels (k, 3) of a mask
    "points",  # positions to locate on a surface (locate_points)
    "part",  # Steps 2-3's Partition, what Step 4 (values_on_curves) works on
    # files and what a writer writes
    "path",  # the file read or written (reconstruct_series: the series written)
    "point_data", "values", "fields",  # what write_mesh / write_tets, write_values, write_vti write
    # batches
    "jobs",  # batch's manifest or job list
    # the method registry
    "name",  # method_of(name): the method looked up
}

#: Records manifill builds and returns (their fields are their contents); no one calls them with options.
RECORDS = {
    "Result", "Reconstruction", "VolumeReconstruction", "BatchResult", "CrossValidation", "GradualCheck",
    "Partition", "CurveValues", "SurfacePoints", "VectorReconstruction",
    "Surface",  # a record too: built by Surface.from_mesh, which is checked
}


def entry_points():
    """``(name, callable)``: every public function, constructor and ``from_*`` constructor."""
    out = []
    for name in manifill.__all__:
        obj = getattr(manifill, name)
        if inspect.isclass(obj) and issubclass(obj, BaseException):
            continue
        if inspect.isclass(obj):
            out += [(f"{name}.{m}", getattr(obj, m)) for m in sorted(vars(obj)) if m.startswith("from_")]
            if name in RECORDS:
                continue
        out.append((name, obj))
    return out


def positional_options(fn):
    """The parameters of ``fn`` that can be passed by position and are not in :data:`POSITIONAL`."""
    bad = []
    for p in inspect.signature(fn).parameters.values():
        if p.kind is p.VAR_POSITIONAL:
            bad.append(f"*{p.name}")
        elif p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.name not in POSITIONAL | {"self", "cls"}:
            bad.append(p.name)
    return bad


def test_records_are_records():
    # the records left out are dataclasses or Results, not entry points hiding from the check below
    for name in RECORDS:
        obj = getattr(manifill, name)
        assert dataclasses.is_dataclass(obj) or issubclass(obj, Result), name


@pytest.mark.parametrize("name, fn", entry_points(), ids=lambda x: x if isinstance(x, str) else "")
def test_options_are_keyword_only(name, fn):
    bad = positional_options(fn)
    code = inspect.unwrap(fn)
    where = f"{inspect.getsourcefile(code).split('src/manifill/')[-1]}:{inspect.getsourcelines(code)[1]}"
    assert not bad, (f"manifill.{name} ({where}) takes the option(s) {', '.join(map(repr, bad))} by position; "
                     f"put them after '*' (or, if one is data, add its name to POSITIONAL with a reason)")


def test_the_check_catches_a_positional_option():
    def good(V, F, idx, vals, *, method=None, **options):
        pass

    def bad(V, F, idx, vals, methods=None, *, seed=0):
        pass

    def star(V, F, *args):
        pass

    assert positional_options(good) == []
    assert positional_options(bad) == ["methods"]
    assert positional_options(star) == ["*args"]


def test_import_manifill_loads_no_command_line_no_adapter_and_no_dask():
    """``import manifill`` in a fresh interpreter: the library alone. The command line, the batch layer, the
    adapters and Dask load when used (``manifill.batch`` on first access; the ``manifill`` command imports them)."""
    import subprocess
    import sys

    code = ("import sys, manifill; print(' '.join(sorted(m for m in sys.modules if m.startswith(('manifill.cli', "
            "'manifill.cluster', 'manifill.adapters', 'dask', 'distributed', 'xarray', 'pandas', 'mne', 'sklearn')))))"
            "; manifill.batch; print('manifill.cluster' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out == ["", "True"], out


def test_renamed_public_names_still_answer_for_one_release_with_a_warning():
    import manifill.surface.reconstruct as rec

    with pytest.warns(DeprecationWarning, match=r"reconstruct\.METHODS is now manifill\.surface\.reconstruct\.METHOD_NAMES"):  # noqa: E501
        old = rec.METHODS
    assert old == rec.METHOD_NAMES == manifill.surface.methods.registry.names(presets=False)
    assert "biharmonic" in old and "default" not in old
    with pytest.raises(AttributeError):
        _ = rec.NO_SUCH_NAME


def test_moved_search_still_answers_at_its_old_place_for_one_release():
    import manifill.linalg.lamsearch as old
    from manifill.linalg.search import grid_search

    with pytest.warns(DeprecationWarning, match=r"lamsearch\.grid_search is now manifill\.linalg\.search\.grid_search"):
        assert old.grid_search is grid_search
