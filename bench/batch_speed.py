"""Batches on Dask (issue 15): many meshes over worker processes, one mesh's many fields over workers, and
the scheduler's cost per task, all measured side by side in one run.

``python -m bench.batch_speed [--smoke] [--parts meshes,fields,overhead] [--jobs 40] [--workers 2]
[--level 8] [--fields 2000] [--samples 1000] [--tasks 2000] [--out FILE]``

1. **meshes**: ``--jobs`` meshes of 40k-160k vertices (seed 0): planar grids ``m x m2`` and
   ellipsoids stretched from ``icosphere(6)`` / ``icosphere(7)``, alternately, each with 100-1,000
   sample vertices (seeded) of a smooth field, written as ``.ply`` + ``.csv`` with a CSV
   manifest (default method, ``.vtu`` outputs). Run (a) **serially**: one fresh child process
   running the jobs' command lines one after another in-process (``manifill.cli.main.main``,
   what a worker runs), its wall time; (b) **``manifill batch``** in a fresh child process with a
   ``LocalCluster`` of ``--workers`` processes (one thread each; start-up and shut-down of the
   cluster included). Reported: both wall times, their ratio (target >= 1.7x with 2 workers on
   this 2-core machine), the peak resident memory of each job (the summary's ``peak_mb``: the
   worker process's peak while the job ran) and per worker the largest, and the jobs' outputs
   compared (every ``value`` array of (b) against (a): largest difference).
2. **fields**: ``icosphere(--level)`` (8: 655,362 vertices), ``--samples`` sample vertices and
   ``--fields`` fields (a smooth field moving in time), default method, written as ``.npy``
   through :func:`manifill.io.stream.reconstruct_series`: (a) one process (``client=None``),
   (b) the same call with a ``distributed.Client`` of a ``LocalCluster`` of ``--workers``
   processes (cluster start included). Each in a fresh child; target (b) >= 1.6x faster.
   The two ``.npy`` files are compared.
3. **overhead**: the scheduler's cost per task: ``--tasks`` empty tasks (``client.submit`` of a
   function that returns at once) on the same kind of cluster, wall time per task, and a batch
   of the same number of no-op jobs through :func:`manifill.batch`'s own submit loop (the
   per-job cost manifill adds: hashing, a summary row). With the per-job time of part 1, the
   on-paper estimate for a 100-node cluster and 10,000 subjects follows (printed, and in
   ``docs/benchmarks.md``).

Writes JSON (``bench/results/batch_speed.json``, or ``--out``) and prints markdown.
``--smoke``: four tiny meshes, a small mesh with 40 fields and 50 tasks, in seconds (for the tests).
"""

import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results" / "batch_speed.json"


def field(P, t=0.0):
    """A smooth field at points P (rows), moving with t."""
    return np.sin(3.0 * (P[:, 0] * np.cos(t) + P[:, 1] * np.sin(t))) + 0.5 * P[:, 2] ** 2 + 0.1 * t


def make_meshes(folder, jobs, sizes, samples, seed=0):
    """The meshes, samples and manifest of part 1; the manifest's path."""
    from manifill.io import write_mesh
    from manifill.mesh.shapes import grid, icosphere

    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    spheres = {}
    rows = []
    for j in range(jobs):
        target = int(rng.integers(sizes[0], sizes[1] + 1))
        if j % 2 == 0:  # a planar grid of about the target size, not square
            m = int(np.sqrt(target / 1.3))
            V, F = grid(int(1.3 * m), m, size=(1.3, 1.0))
        else:  # an ellipsoid from the icosphere nearest above the target
            level = next(lv for lv in range(2, 9) if 10 * 4 ** lv + 2 >= target)
            if level not in spheres:
                spheres[level] = icosphere(level)
            V0, F = spheres[level]
            V = V0 * rng.uniform(0.5, 1.5, size=3)
        n = len(V)
        k = int(rng.integers(samples[0], samples[1] + 1))
        idx = np.sort(rng.choice(n, size=min(k, n // 4), replace=False))
        vals = field(V[idx] / np.abs(V).max())
        mesh, smp = folder / f"m{j:02d}.ply", folder / f"s{j:02d}.csv"
        write_mesh(mesh, V, F)
        with open(smp, "w") as fh:
            fh.write("vertex,value\n" + "".join(f"{i},{v!r}\n" for i, v in zip(idx.tolist(), vals.tolist())))
        rows.append(dict(id=f"j{j:02d}", mesh=mesh.name, samples=smp.name, output=f"out/j{j:02d}.vtu",
                         vertices=n, k=len(idx)))
    (folder / "out").mkdir(exist_ok=True)
    manifest = folder / "jobs.csv"
    with open(manifest, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["id", "mesh", "samples", "output"], extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    (folder / "jobs.json").write_text(json.dumps(rows))
    return manifest


def _child(code, *args, timeout=7200):
    """Run ``code`` (a function of this module, by name) in a fresh interpreter: its JSON answer and wall time."""
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "bench.batch_speed", "--child", code, *map(str, args)], cwd=ROOT,
                       capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise RuntimeError(f"child {code} failed:\n{p.stdout[-2000:]}\n{p.stderr[-4000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1]), wall


def serial_jobs(folder):
    """Part 1 (a): the manifest's command lines one after another in this process."""
    from manifill.cli.main import main
    from manifill.cluster.manifest import read_manifest

    jobs = read_manifest(Path(folder) / "jobs.csv")
    t0 = time.perf_counter()
    seconds = {}
    for job in jobs:
        out = Path(str(job.output).replace(f"{os.sep}out{os.sep}", f"{os.sep}serial{os.sep}"))
        out.parent.mkdir(exist_ok=True)
        argv = ["reconstruct", str(job.mesh), str(job.samples), "-o", str(out), "--quiet", *job.options]
        t = time.perf_counter()
        if main(argv) != 0:
            raise RuntimeError(f"job {job.id} failed serially")
        seconds[job.id] = time.perf_counter() - t
    import resource

    return {"seconds": time.perf_counter() - t0, "job_seconds": seconds,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def batch_jobs(folder, workers):
    """Part 1 (b): ``manifill.batch`` of the manifest on a LocalCluster of ``workers`` processes."""
    import manifill

    t0 = time.perf_counter()
    r = manifill.batch(Path(folder) / "jobs.csv", workers=int(workers), force=True)
    return {"seconds": time.perf_counter() - t0, "counts": r.counts(), "workers": r.workers,
            "rows": [{k: row[k] for k in ("id", "status", "seconds", "peak_mb", "worker", "error")} for row in r.rows]}


def compare_outputs(folder):
    import meshio

    worst = 0.0
    for p in sorted((Path(folder) / "serial").glob("*.vtu")):
        a = meshio.read(p).point_data["value"]
        b = meshio.read(Path(folder) / "out" / p.name).point_data["value"]
        worst = max(worst, float(np.nanmax(np.abs(a - b))))
    return worst


def series_run(folder, level, k, fields, workers):
    """Part 2: one mesh's fields written as .npy, in this process (workers 0) or over a LocalCluster."""

    from manifill.io.stream import reconstruct_series
    from manifill.mesh.shapes import icosphere

    level, k, fields, workers = int(level), int(k), int(fields), int(workers)
    V, F = icosphere(level)
    idx = np.sort(np.random.default_rng([1, k]).choice(len(V), size=k, replace=False))
    vals = np.stack([field(V[idx], t) for t in np.linspace(0, 2 * np.pi, fields)], axis=1)
    out = Path(folder) / f"fields-{workers}.npy"
    t0 = time.perf_counter()
    if workers:
        import distributed

        from manifill.io.distributed import local_cluster

        cluster = local_cluster(workers)
        client = distributed.Client(cluster)
        started = time.perf_counter() - t0
        s = reconstruct_series(V, F, idx, vals, out, client=client)
        client.close()
        cluster.close()
    else:
        started = 0.0
        s = reconstruct_series(V, F, idx, vals, out)
    import resource

    return {"seconds": time.perf_counter() - t0, "cluster_start": started, "vertices": len(V), "k": k,
            "fields": fields, "chunk": s["chunk"], "chunks": s["chunks"],
            "stages": {a: float(b) for a, b in s["seconds"].items()}, "method": s["report"]["method"],
            "peak_mb_here": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def _noop():
    return None


def overhead(folder, tasks, workers):
    """Part 3: the scheduler's wall time per empty task, and manifill.batch's per job on no-op jobs."""

    import distributed

    import manifill
    from manifill.cluster import run as batch_run
    from manifill.io.distributed import local_cluster

    tasks, workers = int(tasks), int(workers)
    cluster = local_cluster(workers)
    client = distributed.Client(cluster)
    client.gather(client.map(lambda x: x, range(20), pure=False))  # warm up
    t = time.perf_counter()
    futures = [client.submit(_noop, pure=False) for _ in range(tasks)]
    distributed.wait(futures)
    per_task = (time.perf_counter() - t) / tasks
    # manifill's own part: the same number of jobs, each hashing its inputs and writing a summary row,
    # with the job itself replaced by a no-op on the worker
    d = Path(folder) / "noop"
    d.mkdir(exist_ok=True)
    (d / "m.ply").write_text("ply\n")
    (d / "s.csv").write_text("vertex,value\n0,1\n")
    jobs = [dict(id=f"n{i}", mesh=d / "m.ply", samples=d / "s.csv", output=d / f"o{i}.vtu") for i in range(tasks)]
    real = batch_run.run_job
    batch_run.run_job = _noop_job
    try:
        t = time.perf_counter()
        r = manifill.batch(jobs, scheduler=client, summary=d / "summary.csv", force=True)
        per_job = (time.perf_counter() - t) / tasks
    finally:
        batch_run.run_job = real
    client.close()
    cluster.close()
    return {"tasks": tasks, "per_task_ms": 1e3 * per_task, "per_job_ms": 1e3 * per_job, "counts": r.counts()}


def _noop_job(job, digest):
    from manifill.cluster.run import _row

    return _row(job, digest, status="done", seconds="0")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--smoke", action="store_true")
    ap.add_argument("--parts", default="meshes,fields,overhead")
    ap.add_argument("--jobs", type=int, default=40)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--level", type=int, default=8)
    ap.add_argument("--fields", type=int, default=2000)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--tasks", type=int, default=2000)
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        fn = {"serial": serial_jobs, "batch": batch_jobs, "series": series_run, "overhead": overhead,
              "compare": compare_outputs}[a.child[0]]
        print(json.dumps(fn(*a.child[1:])))
        return 0
    if a.smoke:
        a.jobs, a.level, a.fields, a.samples, a.tasks = 4, 4, 40, 60, 50
        sizes, samples = (400, 1600), (10, 40)
    else:
        sizes, samples = (40_000, 160_000), (100, 1000)
    parts = a.parts.split(",")
    out = {"command": "python -m bench.batch_speed " + " ".join(argv if argv is not None else sys.argv[1:]),
           "machine": platform.platform(), "cpus": os.cpu_count(), "workers": a.workers}
    t_all = time.perf_counter()
    md = []
    with tempfile.TemporaryDirectory(prefix="batch_speed_") as tmp:
        tmp = Path(tmp)
        if "meshes" in parts:
            make_meshes(tmp / "m", a.jobs, sizes, samples)
            meta = json.loads((tmp / "m" / "jobs.json").read_text())
            ser, _ = _child("serial", tmp / "m")
            par, wall = _child("batch", tmp / "m", a.workers)
            if par["counts"] != {"done": a.jobs}:
                raise RuntimeError(f"the batch did not finish every job: {par['rows']}")
            diff, _ = _child("compare", tmp / "m")
            per_worker = {}
            for row in par["rows"]:
                per_worker[row["worker"]] = max(per_worker.get(row["worker"], 0.0), float(row["peak_mb"] or 0))
            m = {"jobs": a.jobs, "vertices": [r["vertices"] for r in meta], "samples": [r["k"] for r in meta],
                 "serial_seconds": ser["seconds"], "serial_peak_mb": ser["peak_mb"], "batch_seconds": par["seconds"],
                 "batch_wall_with_interpreter": wall, "speedup": ser["seconds"] / par["seconds"],
                 "counts": par["counts"], "peak_mb_per_worker": per_worker,
                 "job_peak_mb": {r["id"]: float(r["peak_mb"] or 0) for r in par["rows"]},
                 "job_seconds_serial": ser["job_seconds"], "max_abs_diff": diff,
                 "job_seconds_batch": {r["id"]: float(r["seconds"] or 0) for r in par["rows"]}}
            out["meshes"] = m
            print(f"meshes: serial {ser['seconds']:.1f} s, batch {par['seconds']:.1f} s -> {m['speedup']:.2f}x",
                  file=sys.stderr, flush=True)
            md += ["| jobs | vertices | samples | serial s | batch s (2 workers) | speed-up | peak MB per worker | "
                   "max diff |", "|---|---|---|---|---|---|---|---|",
                   f"| {a.jobs} | {min(m['vertices']):,}-{max(m['vertices']):,} | {min(m['samples'])}-"
                   f"{max(m['samples'])} | {ser['seconds']:.1f} | {par['seconds']:.1f} | {m['speedup']:.2f}x | "
                   f"{', '.join(f'{v:,.0f}' for v in per_worker.values())} | {diff:.1e} |", ""]
        if "fields" in parts:
            one, _ = _child("series", tmp, a.level, a.samples, a.fields, 0)
            two, _ = _child("series", tmp, a.level, a.samples, a.fields, a.workers)
            x1 = np.load(tmp / "fields-0.npy", mmap_mode="r")
            x2 = np.load(tmp / f"fields-{a.workers}.npy", mmap_mode="r")
            diff = max(float(np.nanmax(np.abs(x1[:, s:s + 50] - x2[:, s:s + 50]))) for s in range(0, a.fields, 50))
            f = {"one": one, "workers": two, "speedup": one["seconds"] / two["seconds"], "max_abs_diff": diff}
            out["fields"] = f
            print(f"fields: one process {one['seconds']:.1f} s, {a.workers} workers {two['seconds']:.1f} s -> "
                  f"{f['speedup']:.2f}x", file=sys.stderr, flush=True)
            md += ["| vertices | samples | fields | method | one process s | 2 workers s (cluster start) | speed-up | "
                   "max diff |", "|---|---|---|---|---|---|---|---|",
                   f"| {one['vertices']:,} | {one['k']:,} | {a.fields:,} | {one['method']} | {one['seconds']:.1f} | "
                   f"{two['seconds']:.1f} ({two['cluster_start']:.1f}) | {f['speedup']:.2f}x | {diff:.1e} |", ""]
        if "overhead" in parts:
            o, _ = _child("overhead", tmp, a.tasks, a.workers)
            out["overhead"] = o
            md += [f"Scheduler: {o['per_task_ms']:.2f} ms per empty task; manifill.batch: {o['per_job_ms']:.2f} ms "
                   f"per no-op job ({a.tasks:,} each, {a.workers} workers).", ""]
            if "meshes" in out:
                per_job = np.mean(list(out["meshes"]["job_seconds_serial"].values()))
                est = 10_000 * (per_job + o["per_job_ms"] / 1e3) / (100 * a.workers)
                out["estimate"] = {"per_job_seconds": float(per_job), "nodes": 100, "workers_per_node": a.workers,
                                   "subjects": 10_000, "hours": est / 3600}
                md += [f"On paper: 10,000 subjects of this mix ({per_job:.2f} s per job, one core) on 100 nodes of "
                       f"{a.workers} workers: {est / 60:.1f} min, of which scheduling "
                       f"{10_000 * o['per_job_ms'] / 1e3 / (100 * a.workers):.2f} s.", ""]
    out["elapsed"] = time.perf_counter() - t_all
    out["markdown"] = "\n".join(md)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(out, indent=1))
    print(out["markdown"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
