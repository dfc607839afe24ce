"""The jobs of a batch: read from a CSV or TOML manifest or given in Python, checked before any runs.

A job is one ``manifill reconstruct`` or ``manifill volume`` command line (:class:`Job`,
:meth:`Job.argv`). A manifest lists them:

CSV
    A header with at least ``mesh,samples,output``; optional ``id``, ``command``
    (``reconstruct``, the default, or ``volume``), ``options`` (command-line arguments,
    split like a shell: ``--method harmonic --bounds 0,1``) and any option of the command
    as a column named after its flag without dashes (``method``, ``max-distance`` or
    ``max_distance``). An empty cell is an option not given; a flag without a value
    (``uncertainty``, ``clean``) takes ``true`` or ``false``.
TOML
    An optional ``[defaults]`` table (any key but ``id`` and ``output``: every job gets
    it unless the job has the same key; its ``options`` come before each job's own),
    then one ``[[job]]`` table per job with the same keys as the CSV columns. Values are
    strings, numbers, booleans (flags) or lists: ``bounds = [0, 1]`` is ``--bounds 0,1``.

Paths are relative to the manifest's folder. The default ``id`` is the output's stem
(``sub01`` for ``out/sub01.vtu``), or its path relative to the manifest's folder when
outputs share a stem. Everything is checked before any job runs, each job's command line
by the command's own parser; a missing input is not checked (it is that job's failure
alone, when it runs). :func:`manifill.cluster.hashing.job_hash` is what tells a re-run that a job is unchanged.

Examples
--------
>>> import os, tempfile
>>> folder = tempfile.mkdtemp()
>>> path = os.path.join(folder, "jobs.csv")
>>> with open(path, "w") as fh:
...     _ = fh.write("mesh,samples,output,method\\nbrain.ply,s1.csv,out/s1.vtu,harmonic\\n")
>>> (job,) = read_manifest(path)
>>> job.id, job.options
('s1', ('--method', 'harmonic'))
>>> [os.path.relpath(a, folder) if os.path.isabs(a) else a for a in job.argv()]
['reconstruct', 'brain.ply', 's1.csv', '-o', 'out/s1.vtu', '--method', 'harmonic']
"""

import collections
import contextlib
import difflib
import functools
import io
import os
import re
import shlex
from dataclasses import dataclass
from pathlib import Path

from ..cli.main import build_parser
from ..errors import OptionError, ReadError
from ..io.formats import Format, FormatView, find_format, register_format
from .readers import FIELDS, REQUIRED, csv_records, read_text, toml_records

__all__ = ["Job", "JOB_COMMANDS", "MANIFEST_FORMATS", "FIELDS", "read_manifest", "jobs_from"]

#: The commands a job may run.
JOB_COMMANDS = ("reconstruct", "volume")
#: The manifest formats, by extension.
def _toml_records(text, path, known):
    return toml_records(text, path)


# manifest: read(text, path, option names) -> [(record, where)]
register_format(Format("CSV of jobs", "manifest", (".csv",), csv_records, text=True))
register_format(Format("TOML of jobs", "manifest", (".toml",), _toml_records))
#: The formats of a batch's manifest (a view of :mod:`manifill.io.formats`' registry).
MANIFEST_FORMATS = FormatView("manifest")
_NEGATIVE = re.compile(r"^-\d+$|^-\d*\.\d+$")  # what argparse reads as a negative number, not a flag
_TRUE, _FALSE = ("true", "yes", "1"), ("false", "no", "0")


@dataclass(frozen=True)
class Job:
    """One job of a batch: a ``manifill reconstruct`` or ``manifill volume`` command line.

    Parameters
    ----------
    id : str
        Its name, unique in the batch (the summary's row).
    command : str
        ``'reconstruct'`` or ``'volume'``.
    mesh, samples, output : Path
        The command's ``MESH SAMPLES -o OUTPUT``; ``samples`` may be a folder or a glob
        pattern of per-time files (a time series).
    options : tuple of str
        The command's other arguments, e.g. ``('--method', 'harmonic', '--bounds', '0,1')``.
    kill_once : str or None
        TESTS ONLY: a marker file; the job's process is killed once, between writing a
        temporary output and renaming it, and the marker created
        (:data:`manifill.io.files.KILL_ONCE_ENV`). ``None`` in real batches.

    Examples
    --------
    >>> job = Job("a", "reconstruct", "m.ply", "s.csv", "a.pvd", ("--uncertainty",))
    >>> job.argv()
    ['reconstruct', 'm.ply', 's.csv', '-o', 'a.pvd', '--uncertainty']
    >>> [str(p) for p in job.outputs()]
    ['a.pvd', 'a']
    """

    id: str
    command: str
    mesh: Path
    samples: Path
    output: Path
    options: tuple = ()
    kill_once: str | None = None

    def __post_init__(self):
        for name in ("mesh", "samples", "output"):
            object.__setattr__(self, name, Path(getattr(self, name)))
        object.__setattr__(self, "options", tuple(str(o) for o in self.options))

    def argv(self):
        """The command line without the program name: ``[command, mesh, samples, '-o', output, *options]``."""
        return [self.command, str(self.mesh), str(self.samples), "-o", str(self.output), *self.options]

    def outputs(self):
        """Every path the job writes: ``-o``, what the format puts beside it, ``--render`` and ``--html``.

        A ``.pvd`` series has its folder ``<stem>/`` beside it, an ``.xdmf`` its ``<stem>.h5``
        (:mod:`manifill.io.series_write`).

        Returns
        -------
        tuple of Path

        Raises
        ------
        OptionError
            The command line is not one the command accepts.
        """
        ns = _parse(self.command, self.argv()[1:], f"job {self.id!r}")
        out = Path(ns.output)
        made = getattr(find_format("series", out, writing=True), "beside", ())  # .xdmf's .h5, .pvd's folder
        paths = [out] + [out.with_name(name.format(stem=out.stem)) for name in made]
        return tuple(paths + [Path(getattr(ns, d)) for d in _spec(self.command).outputs if getattr(ns, d, None)])


class _Spec:
    """A command's parser and its options, as the command line defines them."""

    def __init__(self, parser):
        self.parser = parser
        # argparse lists a parser's actions in no public attribute
        actions = [a for a in parser._actions if a.option_strings and a.dest not in ("help", "version")]
        self.flags = {s: a for a in actions for s in a.option_strings}
        #: dests of the options naming a file the command writes (metavar OUT.<ext>), -o apart
        self.outputs = tuple(a.dest for a in actions if str(a.metavar or "").startswith("OUT."))
        self.path_flags = {s for a in actions if a.dest in self.outputs for s in a.option_strings}


@functools.lru_cache(maxsize=None)
def _spec(command):
    if command not in JOB_COMMANDS:
        raise OptionError(f"command {command!r} is not a batch command; use one of {', '.join(JOB_COMMANDS)}")
    parser = build_parser()
    for action in parser._actions:
        if isinstance(getattr(action, "choices", None), dict) and command in action.choices:
            return _Spec(action.choices[command])
    raise OptionError(f"manifill has no command {command!r}")  # pragma: no cover - JOB_COMMANDS are all there


def _parse(command, args, where):
    """The command's parser applied to ``args`` (nothing runs); its error as an OptionError naming ``where``."""
    spec = _spec(command)
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            return spec.parser.parse_args(args)
    except SystemExit as exc:
        if not exc.code:
            raise OptionError(f"{where}: --help is not a job's option; leave it out") from None
        lines = err.getvalue().strip().splitlines()
        text = lines[-1].removeprefix("manifill: error: ") if lines else f"exit code {exc.code}"
        raise OptionError(f"{where}: manifill {command} refuses its command line: {' '.join(text.split())}") from None


def _check_flags(command, options, where):
    """Flags written in full, -o not among the options, no option given twice."""
    spec, seen = _spec(command), {}
    for tok in options:
        if not tok.startswith("-") or tok in ("-", "--") or _NEGATIVE.match(tok):
            continue
        flag = tok.split("=", 1)[0]
        action = spec.flags.get(flag)
        if action is None:
            full = [s for s in spec.flags if s.startswith(flag)]
            raise OptionError(f"{where}: write the option {flag} in full ({' or '.join(full) or 'see --help'})")
        if action.dest == "output":
            raise OptionError(f"{where}: {flag} belongs in the output column (key), not among the options")
        if action.dest in ("workers", "scheduler"):  # a job already runs on a worker, which cannot start others
            raise OptionError(f"{where}: {flag} is not a job's option (the batch runs each job on a Dask worker); "
                              f"leave it out")
        if action.dest in seen:
            raise OptionError(f"{where}: {'/'.join(action.option_strings)} is given twice ({seen[action.dest]} and "
                              f"{tok}); give it once (a [defaults] key, not its options, lets a job replace it)")
        seen[action.dest] = tok


def _option_names(command):
    return sorted({s[2:] for s in _spec(command).flags if s.startswith("--") and s != "--output"})


def _unknown(name, command, where):
    names = _option_names(command)
    close = difflib.get_close_matches(name.lower().replace("_", "-"), names, n=3)
    hint = f"did you mean {' or '.join(close)}?" if close else f"see 'manifill {command} --help'"
    return OptionError(f"{where}: {name!r} is not an option of manifill {command}; {hint}")


def _scalar(value, name, where):
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise OptionError(f"{where}: option {name} = {value!r}: give a string or a number (true/false is for "
                          f"flags without a value)")
    return repr(value) if isinstance(value, float) else str(value)


def _key_options(name, value, command, where):
    """The arguments of one option given as a column or key, e.g. ``('--method', 'harmonic')``."""
    flag = "--" + name.strip().lower().replace("_", "-")
    action = _spec(command).flags.get(flag)
    if action is None or action.dest == "output":
        raise _unknown(name, command, where)
    if value is None or (isinstance(value, str) and not value.strip()):
        return ()
    if action.nargs == 0:  # a flag: true or false
        word = value if isinstance(value, bool) else str(value).strip().lower()
        if word is True or word in _TRUE:
            return (flag,)
        if word is False or word in _FALSE:
            return ()
        raise OptionError(f"{where}: {name} is a flag without a value; write true or false, not {value!r}")
    if isinstance(value, (list, tuple)):
        items = [_scalar(v, name, where) for v in value]
        if action.nargs in (None, "?"):  # one argument: the list comma-separated (--bounds 0,1, --levels 0,1,2)
            items = [",".join(items)]
    else:
        items = [_scalar(value, name, where).strip()]
    if len(items) == 1 and items[0].startswith("-"):
        return (f"{flag}={items[0]}",)  # argparse would read '-1,1' as a flag
    return (flag, *items)


def _split(options, where):
    if options is None:
        return []
    if isinstance(options, str):
        try:
            return shlex.split(options)
        except ValueError as exc:
            raise OptionError(f"{where}: options {options!r}: {exc}; close the quote") from None
    if isinstance(options, (list, tuple)):
        return [_scalar(o, "options", where) for o in options]
    raise OptionError(f"{where}: options must be a string or a list of strings, not {type(options).__name__}")


def _at(base, value):
    """``value`` as an absolute path, relative ones taken in ``base`` (no symlink resolved)."""
    return Path(os.path.abspath(Path(base) / os.path.expanduser(str(value))))


def with_paths(command, options, fix):
    """``options`` with the values of the output-path options (``--render``, ``--html``) passed through ``fix``."""
    flags, out, nxt = _spec(command).path_flags, [], False
    for tok in options:
        if nxt:
            tok, nxt = str(fix(tok)), False
        elif tok in flags:
            nxt = True
        elif tok.split("=", 1)[0] in flags and "=" in tok:
            flag, value = tok.split("=", 1)
            tok = f"{flag}={fix(value)}"
        out.append(tok)
    return tuple(out)


def _make_job(rec, base, where, bad):
    """One Job from a record (a CSV row, a TOML [[job]] with its defaults, or a dict); ``id`` may be None."""
    for key in REQUIRED:
        value = rec.get(key)
        if value is None or (isinstance(value, str) and not value.strip()):
            raise bad(f"{where}: no {key}; give every job its mesh, samples and output")
        if not isinstance(value, (str, os.PathLike)):
            raise bad(f"{where}: {key} = {value!r} is not a path; write it as a string")
    for key in ("id", "command", "kill_once"):
        if rec.get(key) is not None and not isinstance(rec[key], (str, int) if key == "id" else (str, os.PathLike)):
            raise bad(f"{where}: {key} = {rec[key]!r}: write it as a string")
    command = str(rec.get("command") or "reconstruct").strip().lower()
    if command not in JOB_COMMANDS:
        raise OptionError(f"{where}: command {rec['command']!r} is not a batch command; use "
                          f"{' or '.join(JOB_COMMANDS)}")
    opts = list(_split(rec.get("defaults_options"), where)) + list(_split(rec.get("options"), where))
    for key, value in rec.items():
        if key not in FIELDS and key != "defaults_options":
            opts += _key_options(key, value, command, where)
    mesh, samples, output = (_at(base, rec[k]) for k in REQUIRED)
    opts = with_paths(command, opts, lambda p: _at(base, p))
    _parse(command, [str(mesh), str(samples), "-o", str(output), *opts], where)
    _check_flags(command, opts, where)
    ident = None if rec.get("id") in (None, "") else str(rec["id"]).strip()
    kill = None if not rec.get("kill_once") else str(_at(base, rec["kill_once"]))
    return Job(ident, command, mesh, samples, output, opts, kill)


def _matches(path, pattern):
    """Whether the glob ``pattern`` (absolute) names ``path``; the same test for a folder."""
    return path.match(str(pattern)) if any(c in str(pattern) for c in "*?[") else False


def _finish(jobs, wheres, base, bad, manifest=None):
    """Default ids, then the checks across the batch: ids, outputs, outputs read as inputs."""
    stems = collections.Counter(j.output.stem for j in jobs)
    named = []
    for job in jobs:
        if job.id is None:
            ident = job.output.stem
            if stems[ident] > 1:
                try:
                    ident = job.output.relative_to(Path(os.path.abspath(base))).as_posix()
                except ValueError:
                    ident = job.output.as_posix()
            job = Job(ident, job.command, job.mesh, job.samples, job.output, job.options, job.kill_once)
        named.append(job)
    ids, writers = {}, {}
    for job, where in zip(named, wheres):
        if job.id in ids:
            raise bad(f"{where}: id {job.id!r} is also the id of {ids[job.id]}; give every job its own id")
        ids[job.id] = where
        for key in {out.resolve(): out for out in job.outputs()}:
            if key in writers:
                raise bad(f"{where}: writes {key}, as {writers[key]} does; give every job its own output")
            writers[key] = where
    folders = {}  # every folder above an output -> the first job writing under it (one lookup per input, not a scan)
    for key, where in writers.items():
        for parent in key.parents:
            folders.setdefault(parent, where)
    for job, where in zip(named, wheres):
        mesh, samples = job.mesh.resolve(), job.samples.resolve()
        for out in job.outputs():
            key = out.resolve()
            if key in (mesh, samples) or (manifest is not None and key == manifest):
                raise bad(f"{where}: its output {out} is also an input (the mesh, the samples or the manifest); "
                          f"write the output elsewhere")
            if samples in key.parents or _matches(key, samples):
                raise bad(f"{where}: its output {out} would be read back as one of its samples ({job.samples}); "
                          f"write the output outside them")
        for name, path in (("mesh", mesh), ("samples", samples)):
            other = writers.get(path) or folders.get(path)
            if other is None and any(c in str(path) for c in "*?["):  # a pattern: the outputs it matches
                other = next((w for k, w in writers.items() if _matches(k, path)), None)
            if other is not None:
                raise bad(f"{where}: reads its {name} {path}, which {other} writes; the jobs of a batch run in any "
                          f"order: run that one in an earlier batch")
    return named


def read_manifest(path):
    """The jobs of a manifest (``.csv`` or ``.toml``; the formats in the module docstring).

    Parameters
    ----------
    path : str or Path
        The manifest. Relative paths in it are taken in its folder.

    Returns
    -------
    list of Job
        In the manifest's order; every path absolute.

    Raises
    ------
    ReadError
        The file cannot be read, is not valid CSV/TOML or not ``.csv``/``.toml``; a required
        column or key is missing or a mesh/samples/output empty; two jobs share an id or an
        output; a job writes one of its inputs or another job's input.
    OptionError
        An unknown command or option; a command line the command refuses.
    """
    path = Path(path)
    fmt = find_format("manifest", path)
    if fmt is None:
        ext = path.suffix.lower()
        raise ReadError(f"{path}: a manifest is .csv or .toml, not {ext or 'a file without extension'}; write one "
                        f"of those")
    text = read_text(path)
    known = {n for c in JOB_COMMANDS for n in _option_names(c)}
    records = fmt.read(text, path, known)
    if not records:
        raise ReadError(f"{path}: no jobs; add one row (CSV) or [[job]] table (TOML) per job")
    base = path.resolve().parent
    jobs = [_make_job(rec, base, where, ReadError) for rec, where in records]
    return _finish(jobs, [w for _, w in records], base, ReadError, manifest=path.resolve())


def jobs_from(obj, base=None):
    """The jobs of a batch, from a manifest or from Python.

    Parameters
    ----------
    obj : str, Path, dict, Job or list of dict and Job
        A manifest path (:func:`read_manifest`), or jobs: dicts with the keys of a TOML
        ``[[job]]`` (``mesh``, ``samples``, ``output``; optional ``id``, ``command``,
        ``options`` as a string or list, ``kill_once``, and options by name) or :class:`Job`.
    base : str or Path, optional
        The folder relative paths of dicts and Jobs are taken in (default: the current one).

    Returns
    -------
    list of Job

    Raises
    ------
    OptionError
        Not jobs; any refusal of :func:`read_manifest` for jobs given in Python.

    Examples
    --------
    >>> (job,) = jobs_from([dict(mesh="/d/m.ply", samples="/d/s.csv", output="/d/o.vtu", bounds=[0, 1],
    ...                          uncertainty=True, method="harmonic")])
    >>> job.id, job.options
    ('o', ('--bounds', '0,1', '--uncertainty', '--method', 'harmonic'))
    """
    if isinstance(obj, (str, os.PathLike)):
        return read_manifest(obj)
    if isinstance(obj, (dict, Job)):
        obj = [obj]
    if not isinstance(obj, (list, tuple)) or not obj:
        raise OptionError(f"jobs={type(obj).__name__ if not isinstance(obj, (list, tuple)) else 'an empty list'}: "
                          f"pass a manifest path, or a list of job dicts or Job objects")
    base = Path.cwd() if base is None else Path(base)
    records = []
    for k, item in enumerate(obj, 1):
        if isinstance(item, Job):
            rec = dict(id=item.id, command=item.command, mesh=item.mesh, samples=item.samples, output=item.output,
                       options=list(item.options), kill_once=item.kill_once)
        elif isinstance(item, dict):
            rec = {str(key).strip().lower(): v for key, v in item.items()}
        else:
            raise OptionError(f"job {k} of the list is a {type(item).__name__}; give a dict or a Job")
        label = f" (id {rec['id']!r})" if rec.get("id") is not None else ""
        records.append((rec, f"job {k} of the list{label}"))
    jobs = [_make_job(rec, base, where, OptionError) for rec, where in records]
    return _finish(jobs, [w for _, w in records], base, OptionError)
