"""Batches on a real Dask ``LocalCluster`` (two worker processes): the batch equals the serial runs, a bad job
fails alone, a re-run skips what is finished and redoes what changed, a worker killed mid-job leaves nothing
partial and the job is retried, a job that will not fit is refused with its estimate."""

import csv
import os
import time

import meshio
import numpy as np
import pytest

import manifill
from conftest import run
from manifill.cli.main import main
from manifill.cluster import run as batch_run
from manifill.io import write_mesh
from manifill.mesh.shapes import grid, icosphere

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                       memory_limit="4GB")
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def samples_csv(path, idx, vals):
    path.write_text("vertex,value\n" + "".join(f"{int(i)},{float(v)!r}\n" for i, v in zip(idx, vals)))
    return path


@pytest.fixture
def inputs(tmp_path):
    """Two meshes, four sample files (one of them naming a vertex the mesh does not have)."""
    d = tmp_path / "in"
    d.mkdir()
    V, F = icosphere(3)
    Vg, Fg = grid(12)
    write_mesh(d / "sphere.ply", V, F)
    write_mesh(d / "grid.ply", Vg, Fg)
    rng = np.random.default_rng(0)
    i1 = rng.choice(len(V), 30, replace=False)
    i2 = rng.choice(len(Vg), 20, replace=False)
    samples_csv(d / "s1.csv", i1, V[i1, 0] + V[i1, 2] ** 2)
    samples_csv(d / "s2.csv", i1, np.sin(3 * V[i1, 1]))
    samples_csv(d / "g.csv", i2, Vg[i2, 0] * Vg[i2, 1])
    samples_csv(d / "bad.csv", [0, 5, 10_000], [1.0, 2.0, 3.0])
    return d


def jobs(d, out):
    return [
        dict(id="a", mesh=d / "sphere.ply", samples=d / "s1.csv", output=out / "a.vtu"),
        dict(id="b", mesh=d / "sphere.ply", samples=d / "s2.csv", output=out / "b.vtu", options="--method harmonic"),
        dict(id="c", mesh=d / "grid.ply", samples=d / "g.csv", output=out / "c.vtu",
             options=["--method", "biharmonic", "--bounds", "samples"]),
        dict(id="d", mesh=d / "sphere.ply", samples=d / "s1.csv", output=out / "d.vtu",
             options="--method gp --gp-range 1"),
    ]


def serial(job, out):
    """The job's command line run here, alone, into ``out``."""
    opts = job.get("options", [])
    opts = opts.split() if isinstance(opts, str) else list(opts)
    assert main(["reconstruct", str(job["mesh"]), str(job["samples"]), "-o", str(out), "-q", *opts]) == 0
    return meshio.read(out)


def point_data(path):
    return meshio.read(path).point_data


def hidden(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_the_batch_equals_the_serial_runs(tmp_path, inputs, client):
    out = tmp_path / "out"
    out.mkdir()
    js = jobs(inputs, out)
    result = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert result.ok and result.counts() == {"done": 4}
    assert {r["worker"] for r in result.rows} <= set(client.scheduler_info()["workers"])
    for job in js:
        want = serial(job, tmp_path / f"serial-{job['id']}.vtu").point_data
        got = point_data(job["output"])
        assert set(got) == set(want)
        for name in want:  # a worker's BLAS runs one thread (Dask sets it): equal to rounding
            np.testing.assert_allclose(got[name], want[name], rtol=1e-12, atol=1e-13)
    with open(tmp_path / "s.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["id"] for r in rows] == ["a", "b", "c", "d"]
    assert tuple(rows[0]) == batch_run.SUMMARY_COLUMNS
    assert all(r["status"] == "done" and float(r["seconds"]) > 0 and float(r["peak_mb"]) > 10 for r in rows)
    assert hidden(out) == []


def test_a_bad_job_fails_alone_with_its_one_line_error(tmp_path, inputs, client):
    out = tmp_path / "out"
    out.mkdir()
    js = jobs(inputs, out)[:2] + [dict(id="bad", mesh=inputs / "sphere.ply", samples=inputs / "bad.csv",
                                       output=out / "bad.vtu"),
                                  dict(id="nomesh", mesh=inputs / "missing.ply", samples=inputs / "s1.csv",
                                       output=out / "m.vtu")]
    result = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    status = {r["id"]: r for r in result.rows}
    assert status["a"]["status"] == status["b"]["status"] == "done"
    assert status["bad"]["status"] == status["nomesh"]["status"] == "failed" and not result.ok
    assert "10000" in status["bad"]["error"] and "\n" not in status["bad"]["error"]
    assert "missing.ply" in status["nomesh"]["error"]
    assert not (out / "bad.vtu").exists() and hidden(out) == []


def test_a_rerun_skips_finished_jobs_and_redoes_changed_ones(tmp_path, inputs, client):
    out = tmp_path / "out"
    out.mkdir()
    js = jobs(inputs, out)[:3]
    first = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert first.counts() == {"done": 3}
    again = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert again.counts() == {"skipped": 3}
    for _ in range(2):  # a job recorded as skipped is finished too: any number of re-runs skip it
        assert manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv").counts() == {"skipped": 3}
    before = point_data(out / "b.vtu")["value"].copy()
    rng = np.random.default_rng(5)
    V, _ = icosphere(3)
    i1 = rng.choice(len(V), 30, replace=False)
    samples_csv(inputs / "s2.csv", i1, np.cos(2 * V[i1, 0]))  # job b's input changes
    js[2] = dict(js[2], options=["--method", "biharmonic"])  # job c's options change
    (out / "a.vtu").unlink()  # job a's output is gone
    third = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert third.counts() == {"done": 3}
    assert not np.array_equal(point_data(out / "b.vtu")["value"], before)
    os.utime(inputs / "s1.csv")  # a touched input is not a changed one
    assert manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv").counts() == {"skipped": 3}
    assert manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv", force=True).counts() == {"done": 3}


def test_a_worker_killed_mid_job_is_retried_and_leaves_nothing_partial(tmp_path, inputs, client):
    out = tmp_path / "out"
    out.mkdir()
    marker = tmp_path / "killed.txt"
    js = jobs(inputs, out)[:2]
    js[0] = dict(js[0], kill_once=str(marker))
    result = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert marker.exists() and "killed process" in marker.read_text()  # a worker did die, once
    assert result.counts() == {"done": 2}
    assert hidden(out) == []
    want = serial(js[0], tmp_path / "serial.vtu").point_data
    np.testing.assert_allclose(point_data(out / "a.vtu")["value"], want["value"], rtol=1e-12, atol=1e-13)
    client.wait_for_workers(2, timeout=60)  # the nanny restarted it


def test_stale_temporary_files_of_a_killed_write_are_removed(tmp_path):
    out = tmp_path / "a.vtu"
    (tmp_path / ".a.vtu.1234.tmp.vtu").write_text("half")
    (tmp_path / ".other.vtu.1234.tmp.vtu").write_text("someone else's")
    (tmp_path / ".s").mkdir()
    (tmp_path / ".s.77.tmp").mkdir()
    from manifill.io.files import remove_temporaries

    removed = remove_temporaries(out, dead_only=False)  # what a batch job does before it runs
    assert [p.name for p in removed] == [".a.vtu.1234.tmp.vtu"]
    assert sorted(p.name for p in remove_temporaries(tmp_path / "s.pvd", dead_only=False)) == [".s.77.tmp"]
    assert hidden(tmp_path) == [".other.vtu.1234.tmp.vtu", ".s"]


def test_a_job_that_will_not_fit_its_worker_is_refused_before_the_work(tmp_path, inputs, monkeypatch):
    from manifill.cluster.manifest import jobs_from

    (job,) = jobs_from([dict(id="big", mesh=inputs / "sphere.ply", samples=inputs / "s1.csv",
                             output=tmp_path / "big.vtu")])
    need = batch_run.job_memory(job)
    assert need == 642 * (batch_run.BYTES_PER_VERTEX + batch_run.BYTES_PER_VALUE)
    held = batch_run._rss()
    monkeypatch.setattr(batch_run, "_worker", lambda: ("tcp://w", held + need - 1))
    row = batch_run.run_job(job, "h")
    assert row["status"] == "refused" and "needs about" in row["error"] and not (tmp_path / "big.vtu").exists()
    monkeypatch.setattr(batch_run, "_worker", lambda: ("tcp://w", held + need + 10**9))
    assert batch_run.run_job(job, "h")["status"] == "done"


def test_the_command_line_runs_a_manifest_on_a_given_scheduler(tmp_path, capsys, inputs, client):
    out = tmp_path / "out"
    out.mkdir()
    manifest = tmp_path / "jobs.csv"
    manifest.write_text("id,mesh,samples,output,method\n"
                        f"x,{inputs / 'sphere.ply'},{inputs / 's1.csv'},{out / 'x.vtu'},harmonic\n"
                        f"y,{inputs / 'sphere.ply'},{inputs / 'bad.csv'},{out / 'y.vtu'},\n")
    code, text, err = run(capsys, "batch", manifest, "--scheduler", client.scheduler.address)
    assert code == 1 and "1 of 2 jobs did not finish" in err and "Traceback" not in err
    assert "x: done" in text and "y: failed" in text
    summary = tmp_path / "jobs.summary.csv"
    assert summary.exists() and (out / "x.vtu").exists()
    code, _, err = run(capsys, "batch", manifest, "--scheduler", client.scheduler.address, "--workers", "2")
    assert code == 2 and err.count("\n") == 1 and "leave them out" in err


def test_a_manifest_writing_to_a_new_folder_works_as_written(tmp_path, inputs, client):
    # the README's example writes to out/: every job failed ("folder ... does not exist") until it was made by hand
    out = tmp_path / "out" / "deeper"
    js = jobs(inputs, out)[:2]
    blocked = tmp_path / "file"
    blocked.write_text("a file where a folder should be")
    js.append(dict(js[0], id="blocked", output=blocked / "x.vtu"))
    result = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    status = {r["id"]: r for r in result.rows}
    assert status["a"]["status"] == status["b"]["status"] == "done" and (out / "a.vtu").exists()
    assert status["blocked"]["status"] == "failed"
    assert "could not make the folder of x.vtu" in status["blocked"]["error"]


def test_an_interrupted_batch_keeps_every_finished_job_in_its_summary(tmp_path, inputs, client):
    from manifill.cluster.run import read_summary

    # after SIGTERM the jobs that finished in the last second were missing from the summary and ran again
    out = tmp_path / "out"
    js = jobs(inputs, out)[:3]

    def stop(row, finished, total):
        if finished == 1:  # the signal comes once every job has finished, before the others are recorded
            deadline = time.monotonic() + 60
            while not all((out / f"{j}.vtu").exists() for j in "abc") and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(0.5)
            raise KeyboardInterrupt  # what the CLI's SIGTERM handler raises

    with pytest.raises(KeyboardInterrupt):
        manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv", progress=stop)
    written = {r["id"]: r["status"] for r in read_summary(tmp_path / "s.csv").values()}
    assert written == {"a": "done", "b": "done", "c": "done"}
    again = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert {r["id"] for r in again.rows if r["status"] == "skipped"} == set(written)


def test_a_forced_rerun_cut_short_keeps_the_earlier_rows_of_the_jobs_it_did_not_finish(tmp_path, inputs, client):
    from manifill.cluster.run import read_summary

    # `batch --force` then SIGTERM: the summary held only its header, and the next run redid every job
    js = jobs(inputs, tmp_path / "out")[:3]
    first = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert [r["status"] for r in first.rows] == ["done"] * 3

    def stop(row, finished, total):
        raise KeyboardInterrupt  # the first job's row: the others have not been recorded by this run

    with pytest.raises(KeyboardInterrupt):
        manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv", force=True, progress=stop)
    written = read_summary(tmp_path / "s.csv")
    assert set(written) == {"a", "b", "c"} and {r["status"] for r in written.values()} == {"done"}
    again = manifill.batch(js, scheduler=client, summary=tmp_path / "s.csv")
    assert [r["status"] for r in again.rows] == ["skipped"] * 3


def test_a_killed_worker_leaves_no_warning_on_the_command_lines_stderr(tmp_path, inputs):
    # multiprocessing's resource tracker printed "There appear to be 1 leaked semaphore objects" (two lines)
    import subprocess
    import sys

    from manifill.io.files import KILL_ONCE_ENV

    (tmp_path / "jobs.csv").write_text("id,mesh,samples,output,method\n"
                                       f"a,{inputs / 'sphere.ply'},{inputs / 's1.csv'},out/a.vtu,harmonic\n"
                                       f"b,{inputs / 'sphere.ply'},{inputs / 's2.csv'},out/b.vtu,\n")
    flag = tmp_path / "killed.flag"
    proc = subprocess.run([sys.executable, "-m", "manifill", "batch", "jobs.csv", "--workers", "2"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, **{KILL_ONCE_ENV: str(flag)}))
    assert proc.returncode == 0 and flag.exists(), proc.stderr  # a worker was killed, and its job retried
    assert proc.stderr == ""
    assert (tmp_path / "out" / "a.vtu").exists() and (tmp_path / "out" / "b.vtu").exists()
