"""Every public name renamed in this release is still read under its old name, with one DeprecationWarning that names
the new one, and gives the same object; the renamed report key likewise."""

import importlib

import numpy as np
import pytest

import manifill

RENAMED = [  # module, old name, module of the new name, new name
    ("manifill.surface.reconstruct", "METHODS", "manifill.surface.reconstruct", "METHOD_NAMES"),
    ("manifill.linalg.lamsearch", "grid_search", "manifill.linalg.search", "grid_search"),
    ("manifill.io", "MeshFormat", "manifill.io", "Format"),
    ("manifill.surface.polyharmonic", "SOLVERS", "manifill.surface.polyharmonic", "POLYHARMONIC_SOLVERS"),
    ("manifill.surface.polyharmonic", "WEIGHTS", "manifill.mesh.tetmesh", "TET_WEIGHTS"),
    ("manifill.mesh.tetmesh", "WEIGHTS", "manifill.mesh.tetmesh", "TET_WEIGHTS"),
    ("manifill.solid.tets", "WEIGHTS", "manifill.mesh.tetmesh", "TET_WEIGHTS"),
    ("manifill.solid.reconstruct_volume", "FILL_WEIGHTS", "manifill.mesh.tetmesh", "TET_WEIGHTS"),
    ("manifill.linalg.active_set", "as_bounds", "manifill.linalg.active_set", "bounds_per_field"),
    ("manifill.surface.rbf", "thin_plate", "manifill.surface.rbf", "thin_plate_rbf"),
    ("manifill.surface.options", "CheckOptions", "manifill.surface.options", "Step1Options"),
]


@pytest.mark.parametrize("module, old, where, new", RENAMED)
def test_an_old_name_warns_and_gives_the_new_object(module, old, where, new):
    mod = importlib.import_module(module)
    with pytest.warns(DeprecationWarning, match=rf"{module}\.{old} is now {where}\.{new}"):
        got = getattr(mod, old)
    assert got is getattr(importlib.import_module(where), new)
    assert old not in getattr(mod, "__all__", ())
    with pytest.raises(AttributeError):
        getattr(mod, old + "_no_such_name")


def test_the_fill_report_is_read_under_its_old_key_with_a_warning():
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(2)
    idx = np.arange(0, len(V), 9)
    r = manifill.reconstruct(V, F, idx, V[idx, 2], method="biharmonic")
    assert r.report["fill"]["energy"] == 2 and "harmonic" not in r.report
    with pytest.warns(DeprecationWarning, match=r"report\['fill'\]"):
        assert r.report["harmonic"] is r.report["fill"]
    with pytest.raises(KeyError):
        r.report["no-such-key"]


def test_read_mesh_gives_the_mesh_file_which_unpacks_as_before(tmp_path):
    from manifill.mesh.shapes import icosphere

    V, F = icosphere(1)
    manifill.write_mesh(tmp_path / "m.vtu", V, F, {"t": V[:, 0]})
    m = manifill.read_mesh(tmp_path / "m.vtu")
    V2, F2 = m
    assert np.array_equal(V2, V) and np.array_equal(F2, F) and np.array_equal(m.point_data["t"], V[:, 0])
    assert m.format.name == "VTU"
