"""Memory: what this process can still get, the up-front estimates, and refusals before the work."""

import math
import os
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.sparse.linalg import splu

import manifill.memory
import manifill.solid.reconstruct_volume
import manifill.solid.tetrahedralize
import manifill.linalg.backends
import manifill.mesh.subdivide
import manifill.solid.fill
from manifill import OptionError, ResourceError, SampleError
from manifill.mesh.laplacian import laplacian
from manifill.memory import _available_bytes, available_bytes, human, lu_memory
from manifill.mesh.shapes import grid, icosphere
from manifill.solid.estimates import reconstruct_volume_memory
from manifill.solid.reconstruct_volume import reconstruct_volume, reconstruct_volume_mask, reconstruct_volume_tets
from manifill.linalg.backends import make_linear_solver
from manifill.mesh.subdivide import check_subdivide, subdivide, subdivide_memory, subdivided_size
from manifill.solid.tetrahedralize import tet_count, tetrahedralize, tetrahedralize_memory
from manifill.solid.fill import VoxelFill, fill_memory, tet_fill, tet_fill_memory
from manifill.solid.boundary import boundary_voxels
from manifill.solid.voxels import voxel_laplacian
from manifill.solid.voxelize import voxelize, voxelize_memory

GB = 10**9
UNLIMITED = lambda which: (-1, -1)  # noqa: E731  getrlimit with no limits set
SPHERE = icosphere(3)


def one_line(info):
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def peak_of(f, *args, **kwargs):
    """(result, bytes at the peak) of one call, traced (numpy's allocations are traced)."""
    tracemalloc.start()
    try:
        out = f(*args, **kwargs)
        return out, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def refused_quietly(f, *args, **kwargs):
    """The message of the ResourceError that ``f`` raises, checking that little was allocated first."""
    tracemalloc.start()
    try:
        with pytest.raises(ResourceError) as info:
            f(*args, **kwargs)
        assert tracemalloc.get_traced_memory()[1] < 20e6
    finally:
        tracemalloc.stop()
    return one_line(info)


@pytest.fixture
def little_memory(monkeypatch):
    monkeypatch.setattr(manifill.memory, "available_bytes", lambda: 1000)


@pytest.fixture
def plenty_memory(monkeypatch):
    monkeypatch.setattr(manifill.memory, "available_bytes", lambda: 10**15)


# ---------------------------------------------------------------------------
# available_bytes on a fake /proc and /sys
# ---------------------------------------------------------------------------


def write(root, rel, text):
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def fake_tree(root, *, avail_kb=16 * 10**6, cgroup="0::/\n", status="VmSize:\t 1000 kB\nVmData:\t 500 kB\n"):
    root.mkdir(parents=True, exist_ok=True)
    if avail_kb is not None:
        write(root, "proc/meminfo", f"MemTotal:       32000000 kB\nMemFree: 1 kB\nMemAvailable:   {avail_kb} kB\n")
    write(root, "proc/self/cgroup", cgroup)
    write(root, "proc/self/status", status)
    return root


def v2_group(root, path, limit, used=None, inactive=None):
    base = f"sys/fs/cgroup{path}".rstrip("/")
    write(root, f"{base}/memory.max", f"{limit}\n")
    if used is not None:
        write(root, f"{base}/memory.current", f"{used}\n")
    if inactive is not None:
        write(root, f"{base}/memory.stat", f"anon 5\nfile 9\ninactive_file {inactive}\nactive_file 3\n")


def test_nothing_known_is_unknown(tmp_path):
    assert _available_bytes(str(tmp_path), getrlimit=UNLIMITED) is None


def test_meminfo_alone(tmp_path):
    root = fake_tree(tmp_path, avail_kb=123456)
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 123456 * 1024


def test_v2_nested_limits_take_the_least_room(tmp_path):
    root = fake_tree(tmp_path, cgroup="0::/a/b/c\n")
    v2_group(root, "/", "max")
    v2_group(root, "/a", 8 * GB, used=1 * GB)  # 7 GB of room
    v2_group(root, "/a/b", 4 * GB, used=3 * GB)  # 1 GB: the least, two levels up
    v2_group(root, "/a/b/c", "max", used=2 * GB)
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 1 * GB
    # the inactive file cache is given back before memory is refused
    v2_group(root, "/a/b", 4 * GB, used=3 * GB, inactive=GB // 2)
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 3 * GB // 2
    # the process's own group, when it is the tightest
    v2_group(root, "/a/b/c", 2 * GB + 10**8, used=2 * GB)
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 10**8
    # MemAvailable, when it is less than every cgroup's room
    root2 = fake_tree(tmp_path / "r2", avail_kb=50_000, cgroup="0::/a\n")
    v2_group(root2, "/a", 8 * GB, used=0)
    assert _available_bytes(str(root2), getrlimit=UNLIMITED) == 50_000 * 1024


def test_v2_group_over_its_limit_has_no_room(tmp_path):
    root = fake_tree(tmp_path, cgroup="0::/a\n")
    v2_group(root, "/a", GB, used=2 * GB)
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 0


def test_v1_memory_controller_nested_and_top_level(tmp_path):
    unlimited = 9223372036854771712  # what cgroup v1 writes for no limit
    root = fake_tree(tmp_path, cgroup="5:cpu,cpuacct:/x\n4:memory:/x/y\n0::/\n")
    write(root, "sys/fs/cgroup/memory/memory.limit_in_bytes", f"{unlimited}\n")
    write(root, "sys/fs/cgroup/memory/x/memory.limit_in_bytes", f"{6 * GB}\n")
    write(root, "sys/fs/cgroup/memory/x/memory.usage_in_bytes", f"{4 * GB}\n")
    write(root, "sys/fs/cgroup/memory/x/memory.stat", f"cache 1\ntotal_inactive_file {GB // 4}\n")
    write(root, "sys/fs/cgroup/memory/x/y/memory.limit_in_bytes", f"{unlimited}\n")
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 2 * GB + GB // 4
    # a limit on the top-level group (as before) still counts
    write(root, "sys/fs/cgroup/memory/memory.limit_in_bytes", f"{GB}\n")
    write(root, "sys/fs/cgroup/memory/memory.usage_in_bytes", f"{GB // 2}\n")
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == GB // 2


def test_v1_mounted_below_the_root_cgroup(tmp_path):
    # a container sees its own cgroup as the top of the mount: /docker/abc is mounted at .../memory
    root = fake_tree(tmp_path, cgroup="4:memory:/docker/abc\n")
    write(root, "proc/self/mountinfo",
          "31 23 0:28 / /sys/fs/cgroup rw,relatime - tmpfs tmpfs rw,mode=755\n"
          "35 31 0:32 /docker/abc /sys/fs/cgroup/memory rw,relatime - cgroup cgroup rw,memory\n")
    write(root, "sys/fs/cgroup/memory/memory.limit_in_bytes", f"{3 * GB}\n")
    write(root, "sys/fs/cgroup/memory/memory.usage_in_bytes", f"{GB}\n")
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 2 * GB


def test_v2_found_through_mountinfo(tmp_path):
    root = fake_tree(tmp_path, cgroup="0::/svc/job\n")
    write(root, "proc/self/mountinfo", "41 31 0:38 / /sys/fs/cgroup/unified rw,relatime - cgroup2 cgroup2 rw\n")
    write(root, "sys/fs/cgroup/unified/svc/memory.max", f"{5 * GB}\n")
    write(root, "sys/fs/cgroup/unified/svc/memory.current", f"{GB}\n")
    write(root, "sys/fs/cgroup/svc/memory.max", "1\n")  # not the mount: ignored
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 4 * GB


def test_unreadable_and_garbage_files_are_skipped(tmp_path):
    root = fake_tree(tmp_path, avail_kb=1000, cgroup="0::/a\nnonsense\n4:memory\n")
    v2_group(root, "/a", "max", used="lots")
    write(root, "sys/fs/cgroup/a/memory.stat", "inactive_file many\n")
    write(root, "sys/fs/cgroup/memory.max", "-5\n")
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == 1000 * 1024


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.one_of(st.none(), st.integers(0, 2**40)), st.integers(0, 2**40)),
                min_size=1, max_size=5),
       st.integers(1, 2**30))
def test_v2_room_is_the_minimum_over_the_chain(tmp_path, chain, avail_kb):
    root = tmp_path / f"fake{len(list(tmp_path.iterdir()))}"
    names = [f"g{k}" for k in range(len(chain) - 1)]
    fake_tree(root, avail_kb=avail_kb, cgroup="0::/" + "/".join(names) + "\n")
    rooms = [avail_kb * 1024]
    for depth, (limit, used) in enumerate(chain):
        path = "/" + "/".join(names[:depth])
        v2_group(root, path, "max" if limit is None else limit, used=used)
        if limit is not None:
            rooms.append(max(limit - used, 0))
    assert _available_bytes(str(root), getrlimit=UNLIMITED) == min(rooms)


def test_rlimit_as_less_the_virtual_size(tmp_path):
    import resource

    root = fake_tree(tmp_path, status="VmSize:\t 1048576 kB\nVmData:\t 10 kB\n")  # 1 GiB mapped
    limits = {resource.RLIMIT_AS: (3 * 2**30, -1), resource.RLIMIT_DATA: (-1, -1)}
    assert _available_bytes(str(root), getrlimit=limits.get) == 2 * 2**30
    limits[resource.RLIMIT_DATA] = (2**20 + 10 * 1024, -1)
    assert _available_bytes(str(root), getrlimit=limits.get) == 2**20


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs Linux /proc")
def test_rlimit_as_of_this_process():
    code = """if True:
        import resource
        import manifill.memory as m
        before = m.available_bytes()
        vm = [int(s.split()[1]) * 1024 for s in open("/proc/self/status") if s.startswith("VmSize:")][0]
        resource.setrlimit(resource.RLIMIT_AS, (vm + 2**30, resource.getrlimit(resource.RLIMIT_AS)[1]))
        print(before, m.available_bytes())
    """
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    before, after = (int(x) for x in proc.stdout.split())
    if before < 2 * 2**30:
        pytest.skip("less than 2 GiB available here")
    assert 2**30 - 2**26 < after <= 2**30  # a GiB above the virtual size, less what it grew since


def test_available_bytes_of_this_process():
    avail = available_bytes()
    assert avail is None or (isinstance(avail, int) and avail >= 0)
    if os.path.exists("/proc/meminfo"):
        with open("/proc/meminfo") as fh:
            kb = [int(s.split()[1]) for s in fh if s.startswith("MemAvailable:")]
        assert avail <= kb[0] * 1024 + 10**9  # never more than the system has (give or take its churn)


def test_human():
    assert human(4.6e12) == "4.6 TB" and human(999) == "999 B" and human(float("inf")) == "inf B"


# ---------------------------------------------------------------------------
# estimates against what is allocated
# ---------------------------------------------------------------------------


def within(estimate, actual, factor=3.0):
    return actual / factor <= estimate <= actual * factor


@pytest.mark.parametrize("k, res", [(1, 40), (3, 48), (3, 96)])
def test_voxelize_memory_matches_the_traced_peak(k, res):
    V, F = icosphere(k)
    V = V * [1.0, 0.6, 0.4]
    _, peak = peak_of(voxelize, V, F, resolution=res)
    assert within(voxelize_memory(V, F, res), peak)


def test_voxelize_memory_grows_with_the_grid():
    V, F = SPHERE
    small, big, huge = (voxelize_memory(V, F, r) for r in (100, 200, 3000))
    assert 5 < big / small < 9  # the grid-wide arrays: 8 times the voxels
    assert huge == pytest.approx(18 * 3002**3, rel=0.01)


def test_reconstruct_volume_memory_matches_the_traced_peak():
    V, F = SPHERE
    idx = np.arange(0, len(V), 7)
    r, peak = peak_of(reconstruct_volume, V, F, idx, V[idx, 2], resolution=40)
    estimate = reconstruct_volume_memory(V, F, resolution=40)
    assert within(estimate, peak, 2.0)
    # the unknowns estimated from the enclosed volume: about those solved for
    fill = fill_memory(r.mask.shape, r.report["fill"]["unknowns"], "amg")
    assert within(reconstruct_volume_memory(V, F, resolution=40, fill_solver="amg"), fill, 1.5)
    # a field more costs a grid of values more
    assert reconstruct_volume_memory(V, F, resolution=40, n_fields=3) > estimate + 2 * 8 * 40**3


@pytest.mark.parametrize("mesh, levels", [(icosphere(2), 2), (icosphere(2), 3), (grid(20), 2)])
def test_subdivide_memory_matches_the_traced_peak(mesh, levels):
    V, F = mesh
    X = np.random.default_rng(0).random((len(V), 3))
    (V2, F2, _), peak = peak_of(subdivide, V, F, X, levels=levels)
    assert within(subdivide_memory(len(V), len(F), levels, n_fields=3), peak, 2.0)


def test_subdivided_size():
    V, F = icosphere(1)
    for levels in range(4):
        V2, F2 = subdivide(V, F, levels=levels)
        assert subdivided_size(len(V), len(F), levels) == (len(V2), len(F2))  # exact on a sphere
    V, F = grid(9)
    V2, F2 = subdivide(V, F, levels=3)
    n, m = subdivided_size(len(V), len(F), 3)
    assert m == len(F2) and 0 <= len(V2) - n <= 7  # a disc: Euler's 2 is 1 too many, once per level
    assert subdivided_size(12, 20, 12)[1] == 20 * 4**12
    assert subdivide_memory(12, 20, 0) == 0
    assert subdivide_memory(12, 20, 6) / subdivide_memory(12, 20, 5) == pytest.approx(4, rel=0.1)


def test_tet_count_and_tetrahedralize_memory():
    V, F = icosphere(2)
    for max_volume in (1e-3, 1e-4):
        (TV, TT), peak = peak_of(tetrahedralize, V, F, max_volume=max_volume)
        assert within(tet_count(V, F, max_volume=max_volume), len(TT), 1.5)
        assert within(tetrahedralize_memory(V, F, max_volume=max_volume), peak, 2.0)
    TV, TT = tetrahedralize(V, F)
    assert within(tet_count(V, F), len(TT), 2.0)
    assert tet_count(V, F, max_volume=1e-6) == pytest.approx(1.5 * 4.047e6, rel=0.01)


def test_tet_fill_memory_matches_the_traced_peak():
    V, F = icosphere(2)
    TV, TT = tetrahedralize(V, F, max_volume=1e-4)
    _, peak = peak_of(tet_fill, TV, TT, np.arange(len(V)), V[:, 0], solver="amg")
    assert within(tet_fill_memory(len(TV), len(TT), len(V), "amg"), peak, 2.0)


def lu_entries(A):
    lu = splu(sp.csc_matrix(A))
    return lu.L.nnz + lu.U.nnz


def test_lu_memory_follows_the_fill_in():
    # the factors' entries at 13 bytes and the matrix copied (SuperLU's memory is not traced; its fill-in is exact)
    path = sp.diags_array([-np.ones(2999), 2.5 * np.ones(3000), -np.ones(2999)], offsets=[-1, 0, 1])
    V, F = icosphere(5)
    L = laplacian(V, F)
    surface = (L + sp.eye_array(len(V)))[100:, 100:]
    ball = np.linalg.norm(np.indices((22, 22, 22)) - 10.5, axis=0) < 10
    Lv = voxel_laplacian(ball)
    inner = ~boundary_voxels(ball)[ball]
    solid = Lv[inner][:, inner]
    for A, dim in ((path, 1), (surface, 2), (solid, 3)):
        A = sp.csr_array(A)
        assert within(lu_memory(A.shape[0], A.nnz, dim), 13 * lu_entries(A) + 16 * A.nnz, 2.0), dim
    # and a solid fills in far more than a surface of the same size and entries per row
    assert lu_memory(5000, 35000, 3) > 3 * lu_memory(5000, 35000, 2)


def test_fill_memory_direct_grows_like_the_factors():
    # the old n^(4/3) law made 1.2 GB of factors (measured at 51,000 unknowns) look like 47 MB
    assert fill_memory((50, 50, 50), 51_000, "direct") > 0.9e9
    small, big = fill_memory((30,) * 3, 10_000, "direct"), fill_memory((60,) * 3, 80_000, "direct")
    assert big / small == pytest.approx(8**1.5, rel=0.2)


# ---------------------------------------------------------------------------
# refusals before the work
# ---------------------------------------------------------------------------


def test_huge_resolution_is_refused_with_the_real_memory():
    avail = available_bytes()
    if avail is None or avail > 4e12:
        pytest.skip("no memory limit is known, or it is above 4 TB")
    V, F = icosphere(2)
    idx = np.arange(0, len(V), 5)
    msg = refused_quietly(reconstruct_volume, V, F, idx, V[idx, 0], resolution=3000)
    assert "resolution 3000 (grid 3002 x 3002 x 3002, 27,054,036,008 voxels)" in msg
    assert "needs about 4.7 TB" in msg and "of memory is available" in msg and "(CLI --resolution)" in msg
    msg = refused_quietly(voxelize, V, F, resolution=3000)
    assert msg.startswith("voxelising at resolution 3000") and "needs about 487.0 GB" in msg


def test_reconstruct_volume_refused_before_steps_1_to_6(monkeypatch, little_memory):
    ran = []
    monkeypatch.setattr(manifill.solid.reconstruct_volume, "reconstruct", lambda *a, **k: ran.append("surface"))
    monkeypatch.setattr(manifill.solid.reconstruct_volume, "voxelize", lambda *a, **k: ran.append("voxelize"))
    monkeypatch.setattr(manifill.solid.reconstruct_volume, "tetrahedralize", lambda *a, **k: ran.append("tetgen"))
    V, F = SPHERE
    msg = refused_quietly(reconstruct_volume, V, F, [0, 5], [1.0, 2.0], resolution=24)
    assert msg.startswith("the voxel form at resolution 24 (grid 26 x 26 x 26, 17,576 voxels) (multigrid fill)")
    assert "only 1 kB of memory" in msg and msg.endswith("lower the resolution (CLI --resolution)")
    msg = refused_quietly(reconstruct_volume, V, F, [0, 5], [1.0, 2.0], resolution=24, fill_solver="direct")
    assert "fill_solver='multigrid' (CLI --fill-solver multigrid)" in msg
    msg = refused_quietly(reconstruct_volume, V, F, [0, 5], [1.0, 2.0], form="tets", max_volume=0.01)
    assert msg.startswith("tetrahedralising with max_volume=0.01 (~") and "raise max_volume (CLI --max-volume)" in msg
    assert ran == []


def test_reconstruct_volume_runs_with_plenty(plenty_memory):
    V, F = SPHERE
    idx = np.arange(0, len(V), 9)
    r = reconstruct_volume(V, F, idx, V[idx, 2], resolution=16)
    assert np.isfinite(r.values[r.mask]).all()


def test_tiny_max_volume_is_refused_with_the_real_memory(monkeypatch):
    avail = available_bytes()
    if avail is None or avail > 1e14:
        pytest.skip("no memory limit is known, or it is above 100 TB")
    monkeypatch.setattr(manifill.solid.tetrahedralize.subprocess, "run", lambda *a, **k: pytest.fail("tetgen started"))
    V, F = icosphere(2)
    msg = refused_quietly(tetrahedralize, V, F, max_volume=1e-12)
    assert msg.startswith("tetrahedralising with max_volume=1e-12 (~6,070,567,0")  # 1.5 * 4.047 / 1e-12
    assert "tets) needs about 2428.2 TB but only" in msg
    assert msg.endswith("raise max_volume (CLI --max-volume)")
    msg = refused_quietly(reconstruct_volume, V, F, [0], [1.0], form="tets", max_volume=1e-12)
    assert "raise max_volume (CLI --max-volume)" in msg


def test_tetrahedralize_refused_before_tetgen_starts(monkeypatch, little_memory):
    monkeypatch.setattr(manifill.solid.tetrahedralize.subprocess, "run", lambda *a, **k: pytest.fail("tetgen started"))
    msg = refused_quietly(tetrahedralize, *icosphere(1))
    assert msg.startswith("tetrahedralising with no max_volume (~160 tets)")


def test_subdivision_refused_before_any_level(monkeypatch, little_memory):
    monkeypatch.setattr(manifill.mesh.subdivide, "loop_matrix", lambda *a, **k: pytest.fail("subdivided"))
    V, F = icosphere(2)
    msg = refused_quietly(subdivide, V, F, V[:, 0], levels=1)
    assert msg.startswith("subdividing 1 time (~1,280 faces) needs about ")
    assert msg.endswith("use fewer levels (CLI --subdivide)")
    assert subdivide(V, F, levels=0)[1] is not None  # nothing to do fits anywhere


def test_twelve_levels_refused_with_the_real_memory():
    avail = available_bytes()
    if avail is None or avail > 1e12:
        pytest.skip("no memory limit is known, or it is above 1 TB")
    V, F = icosphere(2)
    msg = refused_quietly(subdivide, V, F, V[:, 0], levels=12)
    assert msg.startswith("subdividing 12 times (~5,368,709,120 faces) needs about 1.1 TB but only ")
    with pytest.raises(ResourceError):
        check_subdivide(len(V), len(F), 12)
    with pytest.raises(ResourceError) as info:
        check_subdivide(len(V), len(F), 10**6)  # counts beyond any memory, worked out in no time
    assert "(CLI --subdivide)" in one_line(info)
    with pytest.raises(OptionError):
        check_subdivide(len(V), len(F), -1)


def test_subdivision_runs_with_plenty(plenty_memory):
    V, F = icosphere(1)
    V2, F2, x2 = subdivide(V, F, V[:, 2], levels=2)
    assert len(F2) == 16 * len(F) and np.allclose(x2, V2[:, 2])


def test_direct_solver_refused_before_factorising(monkeypatch, little_memory):
    monkeypatch.setattr(manifill.linalg.backends, "factorise", lambda *a, **k: pytest.fail("factorised"))
    V, F = icosphere(3)
    A = (laplacian(V, F) + sp.eye_array(len(V))).tocsr()
    msg = refused_quietly(make_linear_solver, A, "direct")
    assert msg.startswith("the sparse LU factorisation of 642 unknowns (solver='direct') needs about")
    assert "use solver='amg' (CLI --solver amg" in msg


def test_direct_solver_runs_with_plenty(plenty_memory):
    V, F = icosphere(2)
    A = (laplacian(V, F) + sp.eye_array(len(V))).tocsr()
    x, _ = make_linear_solver(A, "direct").solve(np.ones(len(V)))
    assert np.allclose(A @ x[:, 0], 1.0)


def test_tet_fill_refused_before_the_laplacian(monkeypatch):
    V, F = icosphere(2)
    TV, TT = tetrahedralize(V, F, max_volume=1e-3)
    monkeypatch.setattr(manifill.solid.fill, "HarmonicSolver", lambda *a, **k: pytest.fail("assembled"))
    monkeypatch.setattr(manifill.memory, "available_bytes", lambda: 1000)
    msg = refused_quietly(tet_fill, TV, TT, np.arange(len(V)), V[:, 0], solver="direct")
    assert msg.startswith(f"the harmonic fill of {len(TV) - len(V):,} tet vertices (direct)")
    assert "use solver='amg' (CLI --fill-solver amg)" in msg
    # the factors of a solid grow like n^1.5, AMG's memory like n
    n = 2_000_000
    assert tet_fill_memory(n, 6 * n, 0, "direct") > 50 * tet_fill_memory(n, 6 * n, 0, "amg")
    assert tet_fill_memory(2 * n, 12 * n, 0, "amg") == pytest.approx(2 * tet_fill_memory(n, 6 * n, 0, "amg"))


def test_tet_mesh_and_mask_input_refused_before_steps_1_to_6(monkeypatch):
    V, F = icosphere(1)
    TV, TT = tetrahedralize(V, F, max_volume=0.01)
    monkeypatch.setattr(manifill.memory, "available_bytes", lambda: 1000)
    rv = manifill.solid.reconstruct_volume
    monkeypatch.setattr(rv, "reconstruct", lambda *a, **k: pytest.fail("surface steps ran"))
    monkeypatch.setattr(rv, "reconstruct_surface", lambda *a, **k: pytest.fail("surface steps ran"))
    monkeypatch.setattr(rv, "digital_surface", lambda *a, **k: pytest.fail("digital surface made"))
    msg = refused_quietly(reconstruct_volume_tets, TV, TT, [0, 1], [1.0, 2.0], fill_solver="direct")
    assert msg.startswith(f"the harmonic fill of {len(TV) - len(V):,} tet vertices (direct) needs about")
    assert "fill_solver='amg' (CLI --fill-solver amg)" in msg
    mask = np.ones((10, 10, 10), dtype=bool)
    msg = refused_quietly(reconstruct_volume_mask, mask, [[0, 0, 0]], [1.0])
    assert msg.startswith("the fill of a 10 x 10 x 10 mask of 1,000 voxels (multigrid) needs about")


def test_voxel_fill_refused_before_its_components(monkeypatch, little_memory):
    monkeypatch.setattr(manifill.solid.fill, "voxel_components", lambda *a, **k: pytest.fail("labelled"))
    mask = np.ones((12, 12, 12), dtype=bool)
    fixed = boundary_voxels(mask)
    msg = refused_quietly(VoxelFill, mask, np.argwhere(fixed))
    assert msg.startswith("the harmonic fill of 1,000 voxels (multigrid) needs about")


@pytest.mark.parametrize("bad", [12.5, float("inf"), float("nan"), True, "12", None, 1, 0])
def test_bad_resolution_is_an_option_error(bad):
    V, F = icosphere(1)
    for f in (lambda: voxelize(V, F, resolution=bad), lambda: voxelize_memory(V, F, bad),
              lambda: reconstruct_volume(V, F, [0], [1.0], resolution=bad)):
        with pytest.raises(OptionError) as info:
            f()
        assert isinstance(info.value, SampleError)  # as voxelize raised before
        assert "resolution" in one_line(info) and "(CLI --resolution)" in one_line(info)


def test_absurd_resolution_is_refused_without_arithmetic_overflow():
    V, F = icosphere(1)
    for res in (10**13, 10**400):
        with pytest.raises(ResourceError) as info:
            voxelize(V, F, resolution=res)
        assert "more than any memory holds" in one_line(info)
    assert voxelize(V, F, resolution=12.0)[0].shape == voxelize(V, F, resolution=12)[0].shape


def test_reconstruct_volume_memory_options():
    V, F = icosphere(1)
    with pytest.raises(OptionError):
        reconstruct_volume_memory(V, F, fill_solver="fast")
    with pytest.raises(OptionError):
        reconstruct_volume_memory(V, F, form="tets", max_volume=-1.0)
    assert reconstruct_volume_memory(V, F, form="tets", max_volume=1e-4) > reconstruct_volume_memory(
        V, F, form="tets", max_volume=1e-3)
    assert math.isfinite(reconstruct_volume_memory(V, F, resolution=10**6))
