"""Small meshes built in code, and slow obviously-correct helpers the tests compare against.

The builders are plain functions (importable as ``from conftest import grid``) so that
they can be used in ``parametrize`` lists and inside hypothesis tests; the fixtures
below expose the fixed ones by name. Every random mesh has a fixed seed.
"""

import numpy as np
import pytest

from manifill.mesh.shapes import grid as _shapes_grid
from manifill.mesh.shapes import icosphere as _shapes_icosphere

# ---------------------------------------------------------------------------
# mesh builders
# ---------------------------------------------------------------------------


def single_triangle():
    """The right triangle (0,0), (1,0), (0,1) in the plane z = 0."""
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    return V, np.array([[0, 1, 2]])


def grid(n=6, m=None, *, size=(1.0, 1.0), diagonal="alternate"):
    """Flat n x m grid of the unit square (manifill.mesh.shapes.grid)."""
    return _shapes_grid(n, m, size=size, diagonal=diagonal)


def icosphere(k=1):
    """Unit icosphere: 10 * 4**k + 2 vertices, all triangles acute."""
    return _shapes_icosphere(k)


def lattice(n=6, m=None, *, squash=1.0):
    """Triangle lattice: equilateral (all angles 60 deg, Delaunay) for squash=1.

    With ``squash`` < 1 the lattice is compressed in y: every triangle has an
    obtuse apex angle (141.8 deg at squash=0.25), so the horizontal interior edges
    have two opposite angles summing to more than pi and a negative cotan weight.
    """
    m = n if m is None else m
    P = np.array([(i + 0.5 * (j % 2), j * np.sqrt(3) / 2 * squash) for j in range(m) for i in range(n)])
    F = []
    for j in range(m - 1):
        for i in range(n - 1):
            a = j * n + i
            b, c, d = a + 1, a + n, a + n + 1
            if j % 2 == 0:
                F += [[a, b, c], [b, d, c]]
            else:
                F += [[a, d, c], [a, b, d]]
    return np.column_stack([P, np.zeros(len(P))]), np.array(F, dtype=np.int64)


def obtuse(n=7):
    """A flat, non-Delaunay mesh: the lattice squashed to a quarter of its height."""
    return lattice(n, squash=0.25)


def irregular(n=9, seed=0):
    """Random-ish irregular flat mesh of the unit square.

    An alternating-diagonal n x n grid whose interior vertices are jittered by up to
    a quarter of the spacing; no two triangles alike, some angles obtuse.
    """
    V, F = grid(n)
    rng = np.random.default_rng(seed)
    h = 1.0 / (n - 1)
    inner = (V[:, 0] > 0) & (V[:, 0] < 1) & (V[:, 1] > 0) & (V[:, 1] < 1)
    V = V.copy()
    V[inner, :2] += rng.uniform(-0.25 * h, 0.25 * h, size=(int(inner.sum()), 2))
    assert (signed_areas_2d(V, F) > 0.05 * h * h).all()  # the fixture is a valid mesh
    return V, F


def two_components():
    """A 4x4 grid (16 vertices) and, disjoint from it, a 3x3 grid (9 vertices)."""
    V1, F1 = grid(4)
    V2, F2 = grid(3)
    V2 = V2 + np.array([3.0, 0.0, 0.0])
    return np.vstack([V1, V2]), np.vstack([F1, F2 + len(V1)])


def torus(nu=12, nv=8, R=2.0, r=0.7):
    """A closed torus of revolution: nu x nv vertices, genus 1."""
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    U, W = np.meshgrid(u, v, indexing="ij")
    U, W = U.ravel(), W.ravel()
    V = np.column_stack([(R + r * np.cos(W)) * np.cos(U), (R + r * np.cos(W)) * np.sin(U), r * np.sin(W)])
    F = []
    for i in range(nu):
        for j in range(nv):
            a = i * nv + j
            b = ((i + 1) % nu) * nv + j
            c = i * nv + (j + 1) % nv
            d = ((i + 1) % nu) * nv + (j + 1) % nv
            F += [[a, b, d], [a, d, c]]
    return V, np.array(F, dtype=np.int64)


def annulus(nt=16, nr=4, r0=1.0, r1=2.0):
    """A flat ring: nr circles of nt vertices between radii r0 and r1; two boundary loops."""
    t = 2 * np.pi * np.arange(nt) / nt
    rad = np.linspace(r0, r1, nr)
    V = np.array([(r * np.cos(a), r * np.sin(a), 0.0) for r in rad for a in t])
    F = []
    for i in range(nr - 1):
        for j in range(nt):
            a, b = i * nt + j, i * nt + (j + 1) % nt
            c, d = a + nt, b + nt
            F += [[a, b, d], [a, d, c]]
    return V, np.array(F, dtype=np.int64)


def nonmanifold():
    """Three triangles sharing the edge (0, 1): one non-manifold edge."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -0.5, 0.8], [0.5, -0.5, -0.8]])
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    return V, F


#: Meshes on which every Laplacian property must hold (name -> builder).
MESHES = {
    "single_triangle": single_triangle,
    "grid": lambda: grid(5),
    "grid_right": lambda: grid(5, diagonal="right"),
    "icosphere": lambda: icosphere(1),
    "lattice": lambda: lattice(5),
    "obtuse": obtuse,
    "irregular": irregular,
    "two_components": two_components,
    "torus": torus,
}

#: Flat meshes (z = 0), for linear precision.
FLAT = {
    "grid": lambda: grid(6),
    "grid_right": lambda: grid(6, diagonal="right"),
    "lattice": lambda: lattice(6),
    "obtuse": obtuse,
    "irregular": irregular,
    "irregular_seed1": lambda: irregular(7, seed=1),
    "annulus": annulus,
}

# ---------------------------------------------------------------------------
# obviously-correct helpers (no manifill code)
# ---------------------------------------------------------------------------


def signed_areas_2d(V, F):
    """Twice the signed area of every triangle of a flat mesh (x, y only)."""
    a, b, c = V[F[:, 0], :2], V[F[:, 1], :2], V[F[:, 2], :2]
    u, w = b - a, c - a
    return u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]


def edge_set(F):
    """The undirected edges of F as a set of (i, j) tuples with i < j."""
    out = set()
    for f in np.asarray(F).tolist():
        for k in range(3):
            i, j = f[k], f[(k + 1) % 3]
            out.add((min(i, j), max(i, j)))
    return out


def adjacency_dense(F, n):
    """Dense 0/1 adjacency matrix of the mesh graph, built edge by edge."""
    A = np.zeros((n, n))
    for i, j in edge_set(F):
        A[i, j] = A[j, i] = 1.0
    return A


def boundary_vertices(F, n):
    """Boolean mask of the vertices on an edge used by exactly one face."""
    count = {}
    for f in np.asarray(F).tolist():
        for k in range(3):
            e = tuple(sorted((f[k], f[(k + 1) % 3])))
            count[e] = count.get(e, 0) + 1
    mask = np.zeros(n, dtype=bool)
    for (i, j), c in count.items():
        if c == 1:
            mask[i] = mask[j] = True
    return mask


def relabel(V, F, perm, rng=None):
    """Renumber vertices so that new vertex i is old vertex perm[i].

    The faces are shuffled and their corners rotated too (orientation kept).
    Returns V', F' and ``inv`` with ``inv[old] = new``.
    """
    perm = np.asarray(perm)
    inv = np.empty_like(perm)
    inv[perm] = np.arange(len(perm))
    F2 = inv[np.asarray(F)]
    if rng is not None:
        F2 = F2[rng.permutation(len(F2))]
        shift = rng.integers(0, 3, size=len(F2))
        F2 = np.array([np.roll(f, s) for f, s in zip(F2, shift)])
    return V[perm], F2, inv


def dense(L):
    """A sparse matrix as a dense numpy array."""
    return L.toarray() if hasattr(L, "toarray") else np.asarray(L)


# ---------------------------------------------------------------------------
# fixtures
# ---------------------------------------------------------------------------


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(name="single_triangle")
def _single_triangle():
    return single_triangle()


@pytest.fixture(name="irregular_mesh")
def _irregular_mesh():
    return irregular()


@pytest.fixture(name="obtuse_mesh")
def _obtuse_mesh():
    return obtuse()


@pytest.fixture(name="two_component_mesh")
def _two_component_mesh():
    return two_components()


# --- a 15 x 15 flat grid with samples of a linear function (linear precision) -----------

GRID_N = 15


def grid_vid(i, j):
    """Vertex index of grid point (i, j) on ``grid(GRID_N)``."""
    return j * GRID_N + i


GRID_SAMPLES = {
    "corners": [grid_vid(0, 0), grid_vid(14, 0), grid_vid(0, 14), grid_vid(14, 14)],
    "corners_center": [grid_vid(0, 0), grid_vid(14, 0), grid_vid(0, 14), grid_vid(14, 14), grid_vid(7, 7)],
    "nine": [grid_vid(i, j) for i in (0, 7, 14) for j in (0, 7, 14)],
}


def linear_field(X):
    """A linear function of position."""
    return 0.3 + 2.0 * X[:, 0] - 1.5 * X[:, 1]


# ---------------------------------------------------------------------------
# the command line, in-process
# ---------------------------------------------------------------------------


def run(capsys, *argv):
    """``manifill ARGV`` in-process: (exit code, stdout, stderr)."""
    from manifill.console import main

    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_usage_error(code, out, err):
    """Exit code 2, exactly one line on stderr, ``manifill: error: ...``, no traceback."""
    assert code == 2
    assert "Traceback" not in out + err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("manifill: error: ")
    return lines[0]


def files(folder):
    """Every file under ``folder``, as sorted relative paths."""
    from pathlib import Path

    return sorted(p.relative_to(folder).as_posix() for p in Path(folder).rglob("*"))


@pytest.fixture
def bars(monkeypatch):
    """Every progress bar a command opens, recording its total and the steps the library told it."""
    import manifill.progress

    opened = []

    class Recorder(manifill.progress.StepBar):
        def __init__(self, total, **options):
            super().__init__(total, **options)
            self.total = total
            opened.append(self)

    monkeypatch.setattr(manifill.progress, "StepBar", Recorder)
    return opened


# ---------------------------------------------------------------------------
# skips: each said in the run's summary (-rs) with the install that enables it
# ---------------------------------------------------------------------------

#: What a skipped test needs -> how to get it.
INSTALLS = {
    "pypardiso": "pip install -e '.[fast]'",
    "scikit-sparse": "apt-get install libsuitesparse-dev && pip install -e '.[cholmod]'",
    "igl": "pip install -e '.[volume]' (libigl)",
    "tetgen": "pip install -e '.[volume]' (tetgen)",
    "pyvista": "pip install -e '.[viz]'",
    "h5py": "pip install -e '.[series]'",
    "nibabel": "pip install -e '.[neuro]'",
    "dask": "pip install -e '.[batch]'",
    "potpourri3d": "pip install -e '.[bench]'",
    "mne": "pip install -e '.[mne]'",
    "scikit-learn": "pip install -e '.[sklearn]'",
}


def _with_install(report):
    if report.skipped and isinstance(report.longrepr, tuple) and len(report.longrepr) == 3:
        path, line, reason = report.longrepr
        hint = next((how for key, how in INSTALLS.items() if key in reason.lower()), None)
        if hint and hint not in reason:
            report.longrepr = (path, line, f"{reason} -> {hint}")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    _with_install(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):  # a module skipped as a whole (importorskip at its top)
    outcome = yield
    _with_install(outcome.get_result())
