"""The discrete Levi-Civita connection (manifill.vectors.connection) against its mathematics.

- Its Laplacian ``L`` (``z^H L z = sum over edges w_ij |z_j - r_ij z_i|^2``) is Hermitian and positive
  semi-definite; on a sphere, where no parallel field exists, it is positive definite.
- On a closed surface its spectrum is potpourri3d's (geometry-central's ``VectorHeatMethodSolver`` builds the same
  intrinsic connection Laplacian: corner angles scaled to ``2 pi``, cotangent weights). The two differ only by a
  gauge (each vertex's frame may be turned: ``L' = D L D^H`` with ``D`` diagonal unitary), which keeps the
  eigenvalues, the moduli of the entries and the products of the entries around a face (the holonomy). On the
  boundary geometry-central scales the angles to ``pi``, manifill leaves them as they are (a constant field on a
  flat mesh is then parallel): there only the weights and the holonomy of the faces away from it agree.
- Around a face the transport turns by the face's curvature; discrete Gauss-Bonnet sums those to ``2 pi chi`` less
  the boundary's turning. The transport into a face (along the corner's bisector) splits a corner's angle excess
  evenly between the two edges of the corner.
- Gauge: renumbering the vertices, shuffling the faces and rotating each face's corners changes the frames but
  not the transport of a vector in space, nor the weights, curvatures and singularities.
- On a flat grid the connection is trivial: a constant field in space is parallel along every edge
  (``z_j = r_ij z_i``), ``L z = 0`` at every vertex, no face has holonomy.
- The face indices of any field sum to the Euler characteristic on a closed surface (2 on the sphere, the
  ellipsoid, the icosahedron and the octahedron, 0 on the torus), are multiples of ``1 / symmetry``, and the
  rotation about ``z`` has one ``+1`` singularity at each pole.
"""

import contextlib

import numpy as np
import pytest

from conftest import relabel
from manifill.mesh.shapes import grid, icosphere, spherical_cap, torus
from manifill.vectors.connection import connection, wrap

try:
    from threadpoolctl import threadpool_limits
except ImportError:  # pragma: no cover - an optional dependency
    threadpool_limits = None


@pytest.fixture(autouse=True)
def _one_blas_thread():
    """Dense complex eigensolves are pathologically slow with threaded OpenBLAS on a loaded machine."""
    with threadpool_limits(1) if threadpool_limits is not None else contextlib.nullcontext():
        yield


def ellipsoid(k=2, axes=(1.0, 0.7, 1.3)):
    V, F = icosphere(k)
    return V * np.asarray(axes), F


MESHES = {
    "sphere": lambda: icosphere(2),
    "ellipsoid": lambda: ellipsoid(2),
    "torus": lambda: torus(8, 16),
    "cap": lambda: spherical_cap(2),
    "grid": lambda: grid(7),
}


def octahedron():
    """Six vertices ``+-e_i``: every face's curvature is ``pi / 2`` (a vertex's angles sum to ``4 pi / 3``)."""
    V = np.vstack([np.eye(3), -np.eye(3)])
    F = [[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 0, 2], [1, 0, 5], [3, 1, 5], [4, 3, 5], [0, 4, 5]]
    return V, np.array(F, dtype=np.int64)


# coarse meshes: a face's curvature (4 pi / 20, pi / 2) is no small correction to a symmetry-4 field's turning
MESHES["icosahedron"] = lambda: icosphere(0)
MESHES["octahedron"] = octahedron
CLOSED = {"sphere": 2, "ellipsoid": 2, "torus": 0, "icosahedron": 2, "octahedron": 2}


def edge_lookup(conn):
    """``(i, j) -> (edge, sign)``: the transport angle from ``i`` to ``j`` is ``sign * transport[edge]``."""
    return {(int(i), int(j)): (e, 1.0) for e, (i, j) in enumerate(conn.edges)} | {
        (int(j), int(i)): (e, -1.0) for e, (i, j) in enumerate(conn.edges)}


def transport_angle(conn, lookup, i, j):
    e, sign = lookup[(int(i), int(j))]
    return sign * conn.transport[e]


def face_holonomy(conn, symmetry=1):
    """The angle of the transport around each face (``i -> j -> k -> i``), wrapped into ``(-pi, pi]``."""
    lookup = edge_lookup(conn)
    out = np.empty(len(conn.F))
    for f, (i, j, k) in enumerate(conn.F):
        out[f] = sum(transport_angle(conn, lookup, a, b) for a, b in ((i, j), (j, k), (k, i)))
    return wrap(symmetry * out)


def cycle_products(L, F):
    """``L_ji L_kj L_ik`` per face ``(i, j, k)``: with ``L_ji = -w_ij r_ij``, minus the product of the three weights
    times the transport around the face; a turn of the frames (``L -> D L D^H``, ``D`` diagonal unitary) cancels
    out of it."""
    L = L.tocsr()
    i, j, k = np.asarray(F).T
    return np.asarray(L[j, i]).ravel() * np.asarray(L[k, j]).ravel() * np.asarray(L[i, k]).ravel()


# ---------------------------------------------------------------------------
# the Laplacian
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(MESHES))
@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_laplacian_hermitian_positive_semidefinite(name, symmetry):
    V, F = MESHES[name]()
    L = connection(V, F).laplacian(symmetry).toarray()
    assert np.abs(L - L.conj().T).max() == 0.0
    ev = np.linalg.eigvalsh(L)
    assert ev.min() >= -1e-12 * ev.max()
    # the quadratic form is the edge sum
    conn = connection(V, F)
    rng = np.random.default_rng(0)
    z = rng.standard_normal(len(V)) + 1j * rng.standard_normal(len(V))
    i, j = conn.edges.T
    r = np.exp(1j * symmetry * conn.transport)
    edge_sum = np.sum(conn.weights * np.abs(z[j] - r * z[i]) ** 2)
    assert np.vdot(z, L @ z).real == pytest.approx(edge_sum, rel=1e-12)
    assert abs(np.vdot(z, L @ z).imag) <= 1e-12 * edge_sum


@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_no_parallel_field_on_the_sphere(symmetry):
    """Hairy ball: the holonomy of the sphere leaves no field with ``L z = 0``."""
    V, F = icosphere(2)
    ev = np.linalg.eigvalsh(connection(V, F).laplacian(symmetry).toarray())
    assert ev.min() > 1e-3 * ev.max()


def boundary_vertices(F, n):
    und = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    edges, count = np.unique(und, axis=0, return_counts=True)
    out = np.zeros(n, dtype=bool)
    out[edges[count == 1].ravel()] = True
    return out


@pytest.mark.parametrize("mesh", [
    pytest.param(lambda: ellipsoid(3), id="ellipsoid3"),
    pytest.param(lambda: torus(8, 16), id="torus"),
])
def test_spectrum_equals_potpourri3d(mesh):
    """Same construction on a closed surface, so same spectrum up to rounding.

    potpourri3d is asked not to flip to the intrinsic Delaunay triangulation (its default), which changes the
    cotangent weights wherever a triangle is obtuse (the ellipsoid has some: negative weights); with the mesh's
    own triangulation the two agree to ~1e-15 relative (angles from ``arctan2``, sums of a dozen terms), and
    ``1e-10`` leaves five orders of magnitude of slack while a wrong transport (its sign, a missing angle scaling)
    moves the spectrum by ``1e-3`` or more.
    """
    pp3d = pytest.importorskip("potpourri3d")
    V, F = mesh()
    L = connection(V, F).laplacian()
    Lp = pp3d.MeshVectorHeatSolver(V, F, use_intrinsic_delaunay=False).get_connection_laplacian()
    ours, theirs = np.linalg.eigvalsh(L.toarray()), np.linalg.eigvalsh(Lp.toarray())
    assert np.abs(ours - theirs).max() <= 1e-10 * ours.max()
    # the gauge-free parts entry by entry: the weights (the torus's near-right angles give weights ~1e-17)
    assert np.abs(np.abs(L.toarray()) - np.abs(Lp.toarray())).max() <= 1e-12 * ours.max()


@pytest.mark.parametrize("mesh", [
    pytest.param(lambda: ellipsoid(3), id="ellipsoid3"),
    pytest.param(lambda: spherical_cap(2), id="cap"),
])
def test_holonomies_equal_potpourri3d(mesh):
    """The transport around each face, entry by entry (gauge-free). On a surface with a boundary only the faces
    away from it: potpourri3d scales a boundary vertex's angles to ``pi``, manifill leaves them as they are (so
    that a constant field on a flat mesh is parallel); the weights agree everywhere."""
    pp3d = pytest.importorskip("potpourri3d")
    V, F = mesh()
    L = connection(V, F).laplacian()
    Lp = pp3d.MeshVectorHeatSolver(V, F, use_intrinsic_delaunay=False).get_connection_laplacian()
    assert np.abs(np.abs(L.toarray()) - np.abs(Lp.toarray())).max() <= 1e-12 * np.abs(L.diagonal()).max()
    ca, cb = cycle_products(L, F), cycle_products(Lp, F)
    inner = ~boundary_vertices(F, len(V))[F].any(axis=1)
    assert inner.mean() > 0.5
    assert np.abs(ca - cb)[inner].max() <= 1e-10 * np.abs(ca).max()
    big = inner & (np.abs(ca) > 1e-6 * np.abs(ca).max())  # the phase of a product with a near-zero weight is noise
    assert big.sum() > 0.5 * inner.sum()
    assert np.abs(np.angle(cb[big] / ca[big])).max() <= 1e-9


def test_spectrum_close_to_potpourri3d_delaunay():
    """With potpourri3d's default (intrinsic Delaunay) the obtuse corners' weights differ: the top of the spectrum
    moves by 7%, the low end (smooth fields) agrees to 5e-4 relative on this ellipsoid."""
    pp3d = pytest.importorskip("potpourri3d")
    V, F = ellipsoid(3)
    ours = np.linalg.eigvalsh(connection(V, F).laplacian().toarray())
    theirs = np.linalg.eigvalsh(pp3d.MeshVectorHeatSolver(V, F).get_connection_laplacian().toarray())
    np.testing.assert_allclose(ours[:20], theirs[:20], rtol=1e-3)


def corner_angles(V, F):
    """Per face and corner, the triangle's angle there (from the edge vectors' dot and cross products)."""
    P = V[F]
    out = np.empty(F.shape)
    for c in range(3):
        u, w = P[:, (c + 1) % 3] - P[:, c], P[:, (c + 2) % 3] - P[:, c]
        out[:, c] = np.arctan2(np.linalg.norm(np.cross(u, w), axis=1), np.sum(u * w, axis=1))
    return out


@pytest.mark.parametrize("name", list(MESHES))
def test_holonomy_is_the_face_curvature(name):
    """Around a face the transport turns by its curvature ``Omega_f`` (modulo 2 pi); discrete Gauss-Bonnet: they
    sum to ``2 pi chi`` less the boundary's turning ``sum over boundary vertices of (pi - angle sum)``."""
    V, F = MESHES[name]()
    conn = connection(V, F)
    np.testing.assert_allclose(wrap(face_holonomy(conn) - conn.face_curvature), 0.0, atol=1e-10)
    chi = len(V) - len(conn.edges) + len(F)
    theta = np.bincount(F.ravel(), corner_angles(V, F).ravel(), len(V))
    turning = np.sum(np.pi - theta[boundary_vertices(F, len(V))])
    assert conn.face_curvature.sum() == pytest.approx(2 * np.pi * chi - turning, abs=1e-9)
    if name in CLOSED:
        assert chi == CLOSED[name]


@pytest.mark.parametrize("name", ["ellipsoid", "cap", "grid", "icosahedron"])
def test_face_transport_splits_the_corner_excess_evenly(name):
    """Carrying a vector from vertex ``i`` into face ``f`` along the corner's bisector, or first along the edge
    ``i -> j`` and then from ``j`` into ``f``, differs by half the two corners' angle excess: ``tau_i - (rho_ij +
    tau_j) = -(e_i + e_j) / 2`` with ``e_v = (s_v - 1) theta_v``, ``theta_v`` the face's angle at ``v`` and ``s_v``
    the vertex's angle scaling (``2 pi`` over its angle sum; 1 on the boundary). Around the face the
    three add up to minus its curvature (``sum e_v = Omega_f``); a transport along an edge (not the bisector)
    would put the whole excess on one end."""
    V, F = MESHES[name]()
    conn = connection(V, F)
    theta = corner_angles(V, F)
    total = np.bincount(F.ravel(), theta.ravel(), len(V))
    scale = np.where(boundary_vertices(F, len(V)), 1.0, 2 * np.pi / total)  # a boundary vertex: unscaled
    excess = (scale[F] - 1.0) * theta
    np.testing.assert_allclose(excess.sum(axis=1), conn.face_curvature, atol=1e-12)
    lookup = edge_lookup(conn)
    tau = conn.face_transport
    for a in range(3):
        b = (a + 1) % 3
        rho = np.array([transport_angle(conn, lookup, i, j) for i, j in F[:, [a, b]]])
        gap = wrap(tau[:, a] - rho - tau[:, b])
        np.testing.assert_allclose(wrap(gap + 0.5 * (excess[:, a] + excess[:, b])), 0.0, atol=1e-10)


# ---------------------------------------------------------------------------
# gauge
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["ellipsoid", "torus", "cap"])
@pytest.mark.parametrize("seed", [0, 1])
def test_relabelling_changes_the_gauge_only(name, seed):
    """Every edge's transport carries a vector in space to the same vector in space, whatever the numbering."""
    V, F = MESHES[name]()
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))
    V2, F2, inv = relabel(V, F, perm, rng)
    a, b = connection(V, F), connection(V2, F2)
    # the normals are the mesh's; the frames may turn about them
    np.testing.assert_allclose(b.frames[:, 2], a.frames[perm, 2], atol=1e-12)
    lb = edge_lookup(b)
    X = rng.standard_normal((len(V), 3))
    Za, Zb = a.to_complex(X), b.to_complex(X[perm])
    i, j = a.edges.T
    # carry X_i along i -> j in each numbering and compare the results in space
    ca = a.to_space(np.exp(1j * a.transport) * Za[i], at=j)
    rb = np.array([transport_angle(b, lb, inv[p], inv[q]) for p, q in a.edges])
    cb = b.to_space(np.exp(1j * rb) * Zb[inv[i]], at=inv[j])
    np.testing.assert_allclose(cb, ca, atol=1e-10)
    # the weights are the same numbers
    wb = np.array([b.weights[lb[(int(inv[p]), int(inv[q]))][0]] for p, q in a.edges])
    np.testing.assert_allclose(wb, a.weights, atol=1e-12)
    # holonomy and curvature of each face are the face's
    key_a = {tuple(sorted(inv[f])): k for k, f in enumerate(F)}
    match = np.array([key_a[tuple(sorted(f))] for f in F2])
    np.testing.assert_allclose(b.face_curvature, a.face_curvature[match], atol=1e-12)
    # the same field has the same singularities
    for s in (1, 2, 4):
        Z = rng.standard_normal(len(V)) + 1j * rng.standard_normal(len(V))
        X = a.to_space(Z)
        Zs = b.to_complex(X[perm])
        if s > 1:  # the power representation of one of the s directions: itself a frame-dependent number
            Za_s, Zb_s = np.abs(Z) * np.exp(1j * s * np.angle(Z)), np.abs(Zs) * np.exp(1j * s * np.angle(Zs))
        else:
            Za_s, Zb_s = Z, Zs
        np.testing.assert_array_equal(b.singularities(Zb_s, s), a.singularities(Za_s, s)[match])


# ---------------------------------------------------------------------------
# a flat grid
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("diagonal", ["alternate", "right"])
def test_flat_grid_connection_is_trivial(diagonal):
    """On a flat mesh, whose boundary angles are left as they are, a constant field in space is parallel along
    every edge (``z_j = r_ij z_i``), so ``L z = 0`` at every vertex, boundary and corners included; no face has
    holonomy, and the constant field has no singularity."""
    V, F = grid(7, 5, size=(1.0, 0.6), diagonal=diagonal)
    conn = connection(V, F)
    n = len(V)
    rng = np.random.default_rng(1)
    for c in ([0.3, -0.7, 0.0], [1.0, 0.0, 0.0], rng.standard_normal(3) * [1, 1, 0]):
        Z = conn.to_complex(np.tile(c, (n, 1)))
        np.testing.assert_allclose(np.abs(Z), np.linalg.norm(c), rtol=1e-14)
        i, j = conn.edges.T
        np.testing.assert_allclose(np.exp(1j * conn.transport) * Z[i], Z[j], atol=1e-14)
        assert np.abs(conn.laplacian() @ Z).max() <= 1e-13
        assert not conn.singularities(Z).any()
    assert np.abs(conn.face_curvature).max() <= 1e-14
    # the frames' normals are the plane's
    np.testing.assert_allclose(np.abs(conn.frames[:, 2]), np.tile([0.0, 0.0, 1.0], (n, 1)), atol=1e-15)


# ---------------------------------------------------------------------------
# singularities
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(CLOSED))
@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_indices_of_random_fields_sum_to_euler_characteristic(name, symmetry):
    V, F = MESHES[name]()
    conn = connection(V, F)
    rng = np.random.default_rng(7)
    fractions = []
    for _ in range(5):
        Z = rng.standard_normal(len(V)) + 1j * rng.standard_normal(len(V))
        ind = conn.singularities(Z, symmetry)
        if len(V) > 100:  # a rough field: many singularities, of both signs
            assert np.count_nonzero(ind) > 10
            assert (ind > 0).any() and (ind < 0).any()
        np.testing.assert_array_equal(ind * symmetry, np.rint(ind * symmetry))
        assert ind.sum() == pytest.approx(CLOSED[name], abs=1e-9)
        fractions.append(np.any(ind != np.rint(ind)))
    assert any(fractions) == (symmetry > 1)  # a line or cross field has fractional indices, an arrow field none


@pytest.mark.parametrize("symmetry", [1, 2, 4])
def test_index_does_not_depend_on_the_representative(symmetry):
    """A line (cross) field's power representation is one number per vertex: turning a sample by a multiple of
    ``2 pi / symmetry`` first does not change it, nor the indices."""
    V, F = ellipsoid(2)
    conn = connection(V, F)
    rng = np.random.default_rng(3)
    u = rng.standard_normal(len(V)) + 1j * rng.standard_normal(len(V))
    turned = u * np.exp(2j * np.pi * rng.integers(0, symmetry, len(V)) / symmetry)

    def power(w):
        return np.abs(w) * np.exp(1j * symmetry * np.angle(w))

    np.testing.assert_array_equal(conn.singularities(power(turned), symmetry), conn.singularities(power(u), symmetry))


@pytest.mark.parametrize("k", [2, 3])
def test_rotation_field_has_two_plus_one_singularities_at_the_poles(k):
    V, F = icosphere(k)
    conn = connection(V, F)
    X = np.cross(conn.frames[:, 2], [0.0, 0.0, 1.0])  # the velocity of a rotation about z
    ind = conn.singularities(conn.to_complex(X))
    f = np.flatnonzero(ind)
    np.testing.assert_array_equal(ind[f], [1.0, 1.0])
    z = np.sort(V[F[f]].mean(axis=1)[:, 2])
    assert z[0] < -0.9 and z[1] > 0.9
    # the gradient of the height (n x (n x e_z)): a source and a sink, +1 each
    G = np.cross(conn.frames[:, 2], X)
    ind = conn.singularities(conn.to_complex(G))
    np.testing.assert_array_equal(np.sort(ind[ind != 0]), [1.0, 1.0])


def test_turning_the_field_keeps_the_indices():
    """Turning the field by one angle in every tangent plane, or scaling it, keeps every index."""
    V, F = ellipsoid(2)
    conn = connection(V, F)
    rng = np.random.default_rng(11)
    Z = rng.standard_normal(len(V)) + 1j * rng.standard_normal(len(V))
    np.testing.assert_array_equal(conn.singularities(Z * np.exp(0.7j)), conn.singularities(Z))
    np.testing.assert_array_equal(conn.singularities(3.0 * Z), conn.singularities(Z))
