"""A batch's manifest: CSV and TOML give the same jobs, every job is a command line the real parser accepts,
relative paths are the manifest's, every bad manifest is refused in one line, and a job's hash changes exactly
when its options, its inputs' bytes or manifill's version do."""

import os
import shlex
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manifill
from manifill.cli.main import build_parser
from manifill.cluster.hashing import inputs, job_hash
from manifill.cluster.manifest import Job, jobs_from, read_manifest
from manifill.errors import ManifillError, OptionError, ReadError

CSV = """id,mesh,samples,output,command,options,method,bounds,uncertainty,max_snap
a,in/m.ply,in/s1.csv,out/a.vtu,,--solver direct,harmonic,"0,1",true,
b,in/m.ply,in/series,out/b.pvd,reconstruct,,,samples,false,0.5
c,in/m.ply,in/s2.csv,out/c.vti,volume,--resolution 32,,,,
"""

TOML = """
[defaults]
mesh = "in/m.ply"

[[job]]
id = "a"
samples = "in/s1.csv"
output = "out/a.vtu"
options = "--solver direct"
method = "harmonic"
bounds = [0, 1]
uncertainty = true

[[job]]
id = "b"
samples = "in/series"
output = "out/b.pvd"
command = "reconstruct"
bounds = "samples"
uncertainty = false
max-snap = 0.5

[[job]]
id = "c"
samples = "in/s2.csv"
output = "out/c.vti"
command = "volume"
options = ["--resolution", 32]
"""


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def one_csv(tmp_path, header, row, name="jobs.csv"):
    return write(tmp_path / name, f"{header}\n{row}\n")


def namespace(argv):
    return vars(build_parser().parse_args(argv))


def test_csv_and_toml_give_the_same_jobs(tmp_path):
    from_csv = read_manifest(write(tmp_path / "jobs.csv", CSV))
    from_toml = read_manifest(write(tmp_path / "jobs.toml", TOML))
    assert from_csv == from_toml
    a, b, c = from_csv
    assert a.options == ("--solver", "direct", "--method", "harmonic", "--bounds", "0,1", "--uncertainty")
    assert b.options == ("--bounds", "samples", "--max-snap", "0.5") and b.samples == tmp_path / "in" / "series"
    assert (c.command, c.options) == ("volume", ("--resolution", "32"))


def test_argv_is_the_hand_written_command_line(tmp_path):
    (a, b, c) = read_manifest(write(tmp_path / "jobs.csv", CSV))
    d = tmp_path
    hand = {"a": f"reconstruct {d}/in/m.ply {d}/in/s1.csv -o {d}/out/a.vtu --solver direct --method harmonic "
                 f"--bounds 0,1 --uncertainty",
            "b": f"reconstruct {d}/in/m.ply {d}/in/series --max-snap 0.5 --bounds samples -o {d}/out/b.pvd",
            "c": f"volume {d}/in/m.ply {d}/in/s2.csv --resolution 32 --output {d}/out/c.vti"}
    for job in (a, b, c):
        assert namespace(job.argv()) == namespace(shlex.split(hand[job.id]))
    assert a.argv() == shlex.split(hand["a"])


@pytest.mark.parametrize("command, column, cell, want, parsed", [
    ("reconstruct", "method", "gp", ("--method", "gp"), "gp"),
    ("reconstruct", "max_distance", "0.25", ("--max-distance", "0.25"), 0.25),
    ("reconstruct", "max-distance", "0.25", ("--max-distance", "0.25"), 0.25),
    ("reconstruct", "max_snap", "0.25", ("--max-snap", "0.25"), 0.25),  # the old name, kept one release
    ("reconstruct", "uncertainty", "true", ("--uncertainty",), True),
    ("reconstruct", "clean", "TRUE", ("--clean",), True),
    ("reconstruct", "uncertainty", "false", (), False),
    ("reconstruct", "uncertainty", "", (), False),
    ("reconstruct", "bounds", "-1,1", ("--bounds=-1,1",), "-1,1"),
    ("reconstruct", "levels", "-2", ("--levels=-2",), "-2"),
    ("volume", "resolution", "48", ("--resolution", "48"), 48),
    ("volume", "allow_open", "true", ("--allow-open",), True),
    ("volume", "form", "tets", ("--form", "tets"), "tets"),
])
def test_an_option_column_is_its_flag(tmp_path, command, column, cell, want, parsed):
    path = one_csv(tmp_path, f"mesh,samples,output,command,{column}", f"m.ply,s.csv,o.vtu,{command},\"{cell}\"")
    (job,) = read_manifest(path)
    assert (job.command, job.options) == (command, want)
    assert namespace(job.argv())[OLD.get(column, column).replace("-", "_")] == parsed


#: Columns under an option's old name -> the option's destination now.
OLD = {"max_snap": "max_distance", "max-snap": "max_distance"}


@pytest.mark.parametrize("key, value, want", [
    ("bounds", "[0, 1]", ("--bounds", "0,1")),
    ("bounds", "[-1.5, 2]", ("--bounds=-1.5,2",)),
    ("levels", "[0, 0.5, 1]", ("--levels", "0,0.5,1")),
    ("levels", "7", ("--levels", "7")),
    ("max_distance", "0.1", ("--max-distance", "0.1")),
    ("uncertainty", "true", ("--uncertainty",)),
    ("check", "false", ()),
])
def test_a_toml_key_is_its_flag(tmp_path, key, value, want):
    path = write(tmp_path / "j.toml",
                 f'[[job]]\nmesh = "m.ply"\nsamples = "s.csv"\noutput = "o.vtu"\n{key} = {value}\n')
    (job,) = read_manifest(path)
    assert job.options == want
    namespace(job.argv())  # the real parser accepts it


def test_defaults_apply_to_every_job_and_a_job_key_replaces_them(tmp_path):
    path = write(tmp_path / "j.toml", '[defaults]\nmethod = "harmonic"\noptions = "--solver direct"\n'
                                      'mesh = "m.ply"\n'
                                      '[[job]]\nsamples = "s.csv"\noutput = "a.vtu"\n'
                                      '[[job]]\nsamples = "s.csv"\noutput = "b.vtu"\nmethod = "gp"\n'
                                      'options = "--noise 0.1"\n')
    a, b = read_manifest(path)
    assert a.options == ("--solver", "direct", "--method", "harmonic")
    assert b.options == ("--solver", "direct", "--noise", "0.1", "--method", "gp")
    assert a.mesh == b.mesh == tmp_path / "m.ply"


def test_relative_paths_are_the_manifests_whatever_the_current_folder(tmp_path, monkeypatch):
    path = write(tmp_path / "proj" / "jobs.csv", "mesh,samples,output,render,html\n"
                                                 "../data/m.ply,s/*.csv,out/a.vtu,pics/a.png,a.html\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    (job,) = read_manifest(Path("..") / "proj" / "jobs.csv")
    proj = tmp_path / "proj"
    assert job.mesh == tmp_path / "data" / "m.ply"
    assert job.samples == proj / "s" / "*.csv"
    assert job.output == proj / "out" / "a.vtu"
    assert job.options == ("--render", str(proj / "pics" / "a.png"), "--html", str(proj / "a.html"))
    assert job.outputs() == (proj / "out" / "a.vtu", proj / "pics" / "a.png", proj / "a.html")
    assert all(Path(a).is_absolute() for a in job.argv()[1:3])
    # dicts from Python: relative to base, else to the current folder
    (d,) = jobs_from([dict(mesh="m.ply", samples="s.csv", output="o.vtu", options="--render=p.png")])
    assert (d.mesh, d.options) == (elsewhere / "m.ply", (f"--render={elsewhere / 'p.png'}",))
    (e,) = jobs_from([dict(mesh="m.ply", samples="s.csv", output="o.vtu")], base=proj)
    assert e.output == proj / "o.vtu"
    assert path.exists()


def test_outputs_name_every_file_a_job_writes():
    pvd = Job("p", "reconstruct", "/d/m.ply", "/d/s", "/d/o/run.pvd", ("--html", "/d/v.html"))
    assert pvd.outputs() == (Path("/d/o/run.pvd"), Path("/d/o/run"), Path("/d/v.html"))
    xdmf = Job("x", "reconstruct", "/d/m.ply", "/d/s", "/d/run.xdmf")
    assert xdmf.outputs() == (Path("/d/run.xdmf"), Path("/d/run.h5"))
    vol = Job("v", "volume", "/d/m.ply", "/d/s.csv", "/d/v.vti", ("--render=/d/v.png",))
    assert vol.outputs() == (Path("/d/v.vti"), Path("/d/v.png"))


def test_default_ids_are_the_output_stems_or_their_paths_when_stems_repeat(tmp_path):
    path = write(tmp_path / "j.csv", "mesh,samples,output\nm.ply,s.csv,sub01/result.vtu\n"
                                     "m.ply,s.csv,sub02/result.vtu\nm.ply,s.csv,other.vtu\n")
    assert [j.id for j in read_manifest(path)] == ["sub01/result.vtu", "sub02/result.vtu", "other"]


HEAD = "id,mesh,samples,output"


@pytest.mark.parametrize("name, text, kind, words", [
    ("j.csv", "mesh,output\nm.ply,o.vtu\n", ReadError, "no samples column"),
    ("j.csv", f"{HEAD}\na,m.ply,,o.vtu\n", ReadError, "j.csv line 2: no samples"),
    ("j.csv", f"{HEAD},command\na,m.ply,s.csv,o.vtu,harmonic\n", OptionError, "'harmonic' is not a batch command"),
    ("j.csv", f"{HEAD}\na,m.ply,s.csv,o.vtu\na,m.ply,s2.csv,o2.vtu\n", ReadError, "line 3: id 'a' is also"),
    ("j.csv", f"{HEAD}\na,m.ply,s.csv,out/o.vtu\nb,m.ply,s2.csv,./out/../out/o.vtu\n", ReadError,
     "as j.csv line 2 does"),
    ("j.csv", f"{HEAD}\na,m.ply,s.csv,o.xdmf\nb,m.ply,s.csv,o.h5\n", ReadError, "o.h5, as j.csv line 2 does"),
    ("j.csv", f"{HEAD}\na,m.vtu,s.csv,m.vtu\n", ReadError, "is also an input"),
    ("j.csv", f"{HEAD}\na,m.ply,series,series/o.csv\n", ReadError, "read back as one of its samples"),
    ("j.csv", f"{HEAD}\na,m.ply,s/*.csv,s/o.csv\n", ReadError, "read back as one of its samples"),
    ("j.csv", f"{HEAD}\na,m.ply,s.csv,o.csv\nb,m.ply,o.csv,p.vtu\n", ReadError, "which j.csv line 2 writes"),
    ("j.csv", f"{HEAD}\na,m.ply,s.csv,series/o.csv\nb,m.ply,series,p.pvd\n", ReadError,
     "reads its samples"),
    ("j.csv", f"{HEAD}\na,m.ply,s.csv,series/o_1.csv\nb,m.ply,series/o_*.csv,p.pvd\n", ReadError,
     "which j.csv line 2 writes"),
    ("j.csv", f"{HEAD},methd\na,m.ply,s.csv,o.vtu,gp\n", OptionError, "did you mean method"),
    ("j.csv", f"{HEAD},command,html\na,m.ply,s.csv,o.vti,volume,v.html\n", OptionError,
     "'html' is not an option of manifill volume"),
    ("j.csv", f"{HEAD},method\na,m.ply,s.csv,o.vtu,nosuch\n", OptionError, "invalid choice: 'nosuch'"),
    ("j.csv", f"{HEAD},uncertainty\na,m.ply,s.csv,o.vtu,maybe\n", OptionError, "write true or false"),
    ("j.csv", f"{HEAD},options\na,m.ply,s.csv,o.vtu,--meth gp\n", OptionError, "write the option --meth in full"),
    ("j.csv", f"{HEAD},options,method\na,m.ply,s.csv,o.vtu,--method gp,harmonic\n", OptionError, "given twice"),
    ("j.csv", f"{HEAD},options\na,m.ply,s.csv,o.vtu,-o x.vtu\n", OptionError, "belongs in the output column"),
    ("j.csv", f"{HEAD},options\na,m.ply,s.csv,o.vtu,--help\n", OptionError, "--help is not a job's option"),
    ("j.csv", f"{HEAD},workers\na,m.ply,s.csv,o.xdmf,2\n", OptionError, "--workers is not a job's option"),
    ("j.csv", f"{HEAD},options\na,m.ply,s.csv,o.xdmf,--scheduler tcp://h:1\n", OptionError,
     "--scheduler is not a job's option"),
    ("j.csv", f"{HEAD},options\na,m.ply,s.csv,o.vtu,extra.csv\n", OptionError, "unrecognized arguments"),
    ("j.csv", f"{HEAD},options\na,m.ply,s.csv,o.vtu,\"--field 'x\"\n", OptionError, "close the quote"),
    ("j.csv", f"{HEAD}\na,m.ply,s.csv,o.vtu,extra\n", ReadError, "5 cells but 4 columns"),
    ("j.csv", "", ReadError, "an empty manifest"),
    ("j.csv", f"{HEAD}\n", ReadError, "no jobs"),
    ("j.json", "{}", ReadError, "a manifest is .csv or .toml, not .json"),
    ("j.toml", "[[job]]\nmesh = 'm.ply'\noutput = 'o.vtu'\n", ReadError, "j.toml [[job]] 1: no samples"),
    ("j.toml", "[[job]]\nmesh = 'm.ply'\nsamples = 's.csv'\noutput = 'o.vtu'\nbounds = true\n", OptionError,
     "give a string or a number"),
    ("j.toml", "[[job]]\nmesh = 'm.ply'\nsamples = 's.csv'\noutput = 3\n", ReadError, "is not a path"),
    ("j.toml", "[job]\nmesh = 'm.ply'\n", ReadError, "write [[job]] (double brackets)"),
    ("j.toml", "[jobs]\nmesh = 'm.ply'\n", ReadError, "unknown table or key 'jobs'"),
    ("j.toml", "[defaults]\noutput = 'o.vtu'\n", ReadError, "[defaults] has output"),
    ("j.toml", "[[job]\n", ReadError, "not valid TOML"),
])
def test_a_bad_manifest_is_refused_in_one_line(tmp_path, name, text, kind, words):
    path = write(tmp_path / name, text)
    with pytest.raises(kind) as info:
        read_manifest(path)
    message = str(info.value)
    assert isinstance(info.value, ManifillError) and isinstance(info.value, ValueError)
    assert words in message and "\n" not in message, message


def test_a_missing_manifest_and_bad_python_jobs_are_refused(tmp_path):
    with pytest.raises(ReadError, match="no such manifest"):
        read_manifest(tmp_path / "none.csv")
    with pytest.raises(OptionError, match="job 2 of the list: no output"):
        jobs_from([dict(mesh="m", samples="s", output="o.vtu"), dict(mesh="m", samples="s")])
    with pytest.raises(OptionError, match="give a dict or a Job"):
        jobs_from([("m", "s", "o")])
    with pytest.raises(OptionError, match="an empty list"):
        jobs_from([])
    with pytest.raises(OptionError, match="id 'x' is also"):
        jobs_from([Job("x", "reconstruct", "m", "s", "a.vtu"), dict(id="x", mesh="m", samples="s", output="b.vtu")])


def test_inputs_are_the_mesh_and_every_sample_file(tmp_path):
    mesh = write(tmp_path / "m.ply", "ply")
    for name in ("s_2.csv", "s_1.csv", ".hidden.csv", "notes.txt"):
        write(tmp_path / "series" / name, name)
    folder = Job("f", "reconstruct", mesh, tmp_path / "series", tmp_path / "o.pvd")
    assert inputs(folder) == sorted([mesh, tmp_path / "series" / "s_1.csv", tmp_path / "series" / "s_2.csv"])
    pattern = Job("g", "reconstruct", mesh, tmp_path / "series" / "s_*.csv", tmp_path / "o.pvd")
    assert inputs(pattern) == inputs(folder)
    with pytest.raises(ReadError, match="no file matches"):
        inputs(Job("h", "reconstruct", mesh, tmp_path / "series" / "t_*.csv", tmp_path / "o.pvd"))
    with pytest.raises(ReadError, match="no such mesh file"):
        job_hash(Job("h", "reconstruct", tmp_path / "no.ply", mesh, tmp_path / "o.vtu"))
    with pytest.raises(ReadError, match="no such samples"):
        job_hash(Job("h", "reconstruct", mesh, tmp_path / "no.csv", tmp_path / "o.vtu"))


def test_the_hash_changes_with_an_option_a_byte_or_the_version_and_nothing_else(tmp_path, monkeypatch):
    mesh = write(tmp_path / "m.ply", "ply\n" + "x" * (3 * 2**20))  # more than one 1 MiB block
    write(tmp_path / "series" / "s_1.csv", "vertex,value\n0,1.0\n")
    write(tmp_path / "series" / "s_2.csv", "vertex,value\n0,2.0\n")
    job = Job("a", "reconstruct", mesh, tmp_path / "series", tmp_path / "o.pvd", ("--method", "harmonic"))
    h = job_hash(job)
    assert len(h) == 64 and job_hash(job) == h
    os.utime(mesh, (1, 1))
    os.utime(tmp_path / "series" / "s_2.csv")
    assert job_hash(job) == h  # touched, not changed
    monkeypatch.chdir(tmp_path)  # the same job written with relative paths
    rel = Job("a", "reconstruct", "m.ply", "series", "o.pvd", ("--method", "harmonic"))
    assert job_hash(rel) == h
    assert job_hash(Job("b", *job.argv()[:3], job.output, job.options)) == h  # the id is not the job's content
    assert job_hash(Job("a", "reconstruct", mesh, job.samples, job.output, ("--method", "biharmonic"))) != h
    assert job_hash(Job("a", "reconstruct", mesh, job.samples, tmp_path / "p.pvd", job.options)) != h
    data = bytearray(mesh.read_bytes())
    data[2**20 + 5] = ord("y")  # one byte, in the second block
    mesh.write_bytes(bytes(data))
    h2 = job_hash(job)
    assert h2 != h
    write(tmp_path / "series" / "s_2.csv", "vertex,value\n0,3.0\n")
    h3 = job_hash(job)
    assert h3 != h2
    (tmp_path / "series" / "s_2.csv").rename(tmp_path / "series" / "s_3.csv")  # a step's time is its name
    assert job_hash(job) != h3
    write(tmp_path / "series" / "readme.txt", "not a sample")
    h4 = job_hash(job)
    monkeypatch.setattr(manifill.version, "__version__", "999.0")
    assert job_hash(job) != h4


METHODS = ["harmonic", "biharmonic", "gp", "gvf-harmonic"]


@settings(max_examples=40, deadline=None)
@given(method=st.none() | st.sampled_from(METHODS),
       bounds=st.none() | st.just("samples") | st.tuples(st.integers(-5, 5), st.integers(6, 9)),
       uncertainty=st.booleans(),
       max_snap=st.none() | st.floats(1e-3, 10.0),
       levels=st.none() | st.lists(st.floats(-10, 10, allow_nan=False), min_size=2, max_size=4),
       render=st.booleans())
def test_every_job_is_a_command_line_the_parser_reads_back(method, bounds, uncertainty, max_snap, levels, render):
    keys = dict(method=method, uncertainty=uncertainty, max_snap=max_snap, levels=levels,
                bounds=list(bounds) if isinstance(bounds, tuple) else bounds)
    if render:
        keys["render"] = "/p/pic.png"
    (job,) = jobs_from([dict(mesh="/d/m.ply", samples="/d/s.csv", output="/d/o.vtu",
                             **{k: v for k, v in keys.items() if v is not None})])
    ns = namespace(job.argv())
    assert (ns["command"], ns["mesh"], ns["samples"], ns["output"]) == ("reconstruct", "/d/m.ply", "/d/s.csv",
                                                                         "/d/o.vtu")
    assert ns["method"] == method and ns["uncertainty"] is uncertainty and ns["max_distance"] == max_snap
    assert ns["bounds"] == (None if bounds is None else bounds if isinstance(bounds, str) else
                            f"{bounds[0]},{bounds[1]}")
    assert ns["levels"] == (None if levels is None else ",".join(repr(v) for v in levels))
    if levels is not None:
        assert [float(v) for v in ns["levels"].split(",")] == levels
    assert job.outputs() == ((Path("/d/o.vtu"), Path("/p/pic.png")) if render else (Path("/d/o.vtu"),))


def test_a_summary_that_is_a_jobs_input_or_output_is_refused_before_anything_runs(tmp_path):
    import manifill

    (tmp_path / "m.ply").write_text("ply\n")
    (tmp_path / "s.csv").write_text("vertex,value\n0,1\n")
    job = dict(mesh=tmp_path / "m.ply", samples=tmp_path / "s.csv", output=tmp_path / "o.vtu")
    for clash, word in (("s.csv", "input"), ("o.vtu", "output")):
        with pytest.raises(OptionError, match=f"also a job's {word}"):
            manifill.batch([job], summary=tmp_path / clash)
    assert (tmp_path / "s.csv").read_text() == "vertex,value\n0,1\n" and not (tmp_path / "o.vtu").exists()
