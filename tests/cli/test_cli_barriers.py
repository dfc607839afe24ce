"""``--barriers FILE``: paths of vertex indices (.txt, .csv), positions (.csv with x, y, z), per-face labels (.npy);
the values equal the library's; damaged or impossible barriers end in one line, exit 2, nothing written."""

import meshio
import numpy as np
import pytest

import manifill
from conftest import assert_usage_error, files, run
from manifill.io import write_mesh
from manifill.mesh.shapes import grid

V, F = grid(15)
WALL = np.flatnonzero(np.isclose(V[:, 0], 0.5))
WALL = WALL[np.argsort(V[WALL, 1])]
IDX = np.sort(np.random.default_rng(0).choice(np.flatnonzero(~np.isclose(V[:, 0], 0.5)), 40, replace=False))


def step(P):
    return P[:, 1] + (P[:, 0] > 0.5)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    folder = tmp_path_factory.mktemp("barriers")
    write_mesh(folder / "m.ply", V, F)
    (folder / "s.csv").write_text("vertex,u\n" + "".join(f"{i},{v!r}\n" for i, v in zip(IDX, step(V[IDX]).tolist())))
    (folder / "wall.txt").write_text("# the wall\n" + " ".join(map(str, WALL[:8])) + "\n"
                                     + ", ".join(map(str, WALL[7:])) + "\n")
    (folder / "wall.csv").write_text("barrier,x,y,z\n" + "".join(f"0,{a!r},{b!r},{c!r}\n"
                                                                 for a, b, c in V[np.r_[WALL[::3], WALL[-1]]].tolist()))
    np.save(folder / "labels.npy", (V[F].mean(axis=1)[:, 0] > 0.5).astype(np.int32))
    return folder


@pytest.mark.parametrize("name", ["wall.txt", "wall.csv", "labels.npy"])
def test_every_barrier_file_gives_the_library_s_values(tmp_path, capsys, case, name):
    out = tmp_path / "o.vtu"
    code, text, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o", out, "--method", "biharmonic",
                          "--barriers", case / name)
    assert code == 0, err
    assert "barriers: 14 edges, 15 vertices split, 2 pieces" in text
    r = manifill.reconstruct(V, F, IDX, step(V[IDX]), method="biharmonic", barriers=[WALL])
    assert np.allclose(meshio.read(out).point_data["u"], r.values, atol=1e-12)


def test_cv_takes_barriers(capsys, case):
    args = ("cv", case / "m.ply", case / "s.csv", "--methods", "harmonic,biharmonic", "--folds", "4")
    code, text, err = run(capsys, *args, "--barriers", case / "wall.txt")
    assert code == 0, err
    cv = manifill.cross_validate(V, F, IDX, step(V[IDX]), methods=["harmonic", "biharmonic"], folds=4,
                                 barriers=[WALL])
    assert f"{100 * cv.errors['biharmonic']:.3g}%" in text
    code, plain, err = run(capsys, *args)
    assert code == 0 and plain.split("rank")[1] != text.split("rank")[1]


def test_clean_renumbers_the_barriers_and_stl_refuses_them_by_index(tmp_path, capsys, case):
    """--clean merges an unwelded copy of vertex 0 (put first in the file): the barrier file's indices, in the
    file's numbering, are renumbered with the samples; an STL keeps no vertex numbers, so index barriers are
    refused (positions are not)."""
    V2, F2 = np.vstack([V[:1], V]), F + 1
    f0 = np.flatnonzero((F == 0).any(axis=1))[0]
    F2[f0] = np.where(F[f0] == 0, 0, F[f0] + 1)
    write_mesh(tmp_path / "u.vtp", V2, F2)
    rows = zip(IDX, step(V[IDX]).tolist())
    (tmp_path / "s.csv").write_text("vertex,u\n" + "".join(f"{i + 1},{v!r}\n" for i, v in rows))
    (tmp_path / "w.txt").write_text(" ".join(str(w + 1) for w in WALL) + "\n")
    out = tmp_path / "o.vtu"
    code, _, err = run(capsys, "reconstruct", tmp_path / "u.vtp", tmp_path / "s.csv", "-o", out, "--method",
                       "biharmonic", "--barriers", tmp_path / "w.txt", "--clean")
    assert code == 0, err
    ref = manifill.reconstruct(V, F, IDX, step(V[IDX]), method="biharmonic", barriers=[WALL]).values
    assert np.abs(meshio.read(out).point_data["u"] - ref).max() < 1e-12
    write_mesh(tmp_path / "m.stl", V, F)
    code, o, err = run(capsys, "reconstruct", tmp_path / "m.stl", case / "wall.csv", "-o", out,
                       "--barriers", case / "wall.txt")
    assert "give the barriers as positions" in assert_usage_error(code, o, err)


@pytest.mark.parametrize("content, name, word", [
    ("0 1 x\n", "b.txt", "line 1: 'x' is not a number"),
    ("0 1.5 2\n", "b.txt", "not a vertex index"),
    ("# nothing\n", "b.txt", "no barrier"),
    ("0 99999\n", "b.txt", "outside"),
    ("0 1\n", "b.dat", "barriers are read from .txt, .csv, .npy"),
    (None, "b.npy", "per-face integer labels"),
])
def test_bad_barrier_files_are_one_line_and_write_nothing(tmp_path, capsys, case, content, name, word):
    bad = tmp_path / name
    if content is None:
        np.save(bad, np.zeros((3, 3)))
    else:
        bad.write_text(content)
    before = files(tmp_path)
    code, out, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o", tmp_path / "o.vtu",
                         "--barriers", bad)
    assert word in assert_usage_error(code, out, err)
    assert files(tmp_path) == before


def test_a_piece_without_samples_is_refused_before_the_work(tmp_path, capsys, case):
    left = IDX[V[IDX, 0] < 0.5]
    (tmp_path / "left.csv").write_text("vertex,u\n" + "".join(f"{i},1.0\n" for i in left))
    code, out, err = run(capsys, "reconstruct", case / "m.ply", tmp_path / "left.csv", "-o", tmp_path / "o.vtu",
                         "--barriers", case / "wall.txt")
    assert "--on-empty nan" in assert_usage_error(code, out, err) or "on_empty" in err
