"""Reading a batch manifest's text: the records of a CSV (one per row) or a TOML file (one per ``[[job]]``).

Each record is ``(dict of field or option name -> value, where)``, ``where`` naming the
line or table for the errors; :mod:`manifill.cluster.manifest` turns records into jobs and
checks them. Only the file's own shape is checked here: a header, its names, the tables.
"""

import csv
import difflib
import io

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser as the tomli package (the [batch] extra has it)
    import tomli as tomllib  # type: ignore[no-redef]

from ..errors import OptionError, ReadError

#: A job's own fields (the manifest's other columns are the command's options).
FIELDS = ("id", "command", "mesh", "samples", "output", "options", "kill_once")
#: The fields every job has.
REQUIRED = ("mesh", "samples", "output")
_COMMANDS = ("reconstruct", "volume")


def read_text(path):
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ReadError(f"{path}: no such manifest; check the path") from None
    except UnicodeDecodeError:
        raise ReadError(f"{path}: the manifest is not UTF-8 text; save it as UTF-8") from None
    except OSError as exc:
        raise ReadError(f"{path}: cannot read the manifest ({exc.strerror or exc}); check its permissions") from None


def csv_records(text, path, known):
    rows = csv.reader(io.StringIO(text))
    try:
        header = next((r for r in rows if any(c.strip() for c in r)), None)
        if header is None:
            raise ReadError(f"{path}: an empty manifest; write a header mesh,samples,output and one row per job")
        names = [h.strip().lower() for h in header]
        for i, name in enumerate(names):
            if not name:
                raise ReadError(f"{path}: column {i + 1} of the header has no name; name it or remove it")
            if names.index(name) != i:
                raise ReadError(f"{path}: column {name!r} appears twice in the header; keep one")
        missing = [k for k in REQUIRED if k not in names]
        if missing:
            raise ReadError(f"{path}: no {', '.join(missing)} column; the header needs at least mesh,samples,output")
        for name in names:
            if name not in FIELDS and name.replace("_", "-") not in known:
                close = difflib.get_close_matches(name.replace("_", "-"), sorted(known) + list(FIELDS), n=3)
                hint = f"did you mean {' or '.join(close)}?" if close else "see 'manifill reconstruct --help'"
                raise OptionError(f"{path}: column {name!r} is neither a job's field ({', '.join(FIELDS)}) nor an "
                                  f"option of manifill {' or '.join(_COMMANDS)}; {hint}")
        records = []
        for row in rows:
            if not any(c.strip() for c in row):
                continue
            where = f"{path.name} line {rows.line_num}"
            if len(row) > len(names):
                raise ReadError(f"{where}: {len(row)} cells but {len(names)} columns in the header; quote a cell "
                                f"holding a comma")
            records.append(({n: c.strip() for n, c in zip(names, row) if c.strip()}, where))
    except csv.Error as exc:
        raise ReadError(f"{path} line {rows.line_num}: not valid CSV ({exc})") from None
    return records


def toml_records(text, path):
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ReadError(f"{path}: not valid TOML ({exc})") from None
    extra = [k for k in doc if k not in ("defaults", "job")]
    if extra:
        raise ReadError(f"{path}: unknown table or key {extra[0]!r}; a manifest has a [defaults] table and [[job]] "
                        f"tables")
    defaults, jobs = doc.get("defaults", {}), doc.get("job", [])
    if not isinstance(defaults, dict):
        raise ReadError(f"{path}: defaults must be a table; write [defaults]")
    if not isinstance(jobs, list) or not all(isinstance(j, dict) for j in jobs):
        raise ReadError(f"{path}: job must be tables; write [[job]] (double brackets) before each job")
    defaults = {key.strip().lower(): v for key, v in defaults.items()}
    for key in ("id", "output"):
        if key in defaults:
            raise ReadError(f"{path}: [defaults] has {key}, which is every job's own; move it to the [[job]] tables")
    base = {k: v for k, v in defaults.items() if k != "options"}
    records = []
    for k, job in enumerate(jobs, 1):
        where = f"{path.name} [[job]] {k}" + (f" (id {job['id']!r})" if "id" in job else "")
        rec = {**base, **{key.strip().lower(): v for key, v in job.items()}}
        rec["defaults_options"] = defaults.get("options")
        records.append((rec, where))
    return records
