"""What a batch job depends on: its input files, and one digest of them and its command line.

A re-run of a batch compares a job's :func:`job_hash` with the one its summary recorded:
equal, and the outputs there, the job is skipped.
"""

import glob
import hashlib
import json
import os
from pathlib import Path

from .. import version
from ..errors import ReadError
from ..io.samples import SAMPLE_FORMATS
from .manifest import with_paths

__all__ = ["inputs", "job_hash"]
_BLOCK = 2**20


def inputs(job):
    """The files a job reads, sorted: its mesh and its samples (every sample file of a folder or pattern).

    A folder's sample files are those a time series reads (:data:`manifill.io.SAMPLE_FORMATS`,
    not hidden).

    Returns
    -------
    list of Path

    Raises
    ------
    ReadError
        The mesh or the samples do not exist (a pattern: match no file).
    """
    mesh, samples = Path(job.mesh), Path(job.samples)
    if not mesh.is_file():
        raise ReadError(f"job {job.id!r}: {mesh}: no such mesh file; check the path")
    if samples.is_dir():
        files = [p for p in samples.iterdir() if p.is_file() and not p.name.startswith(".")
                 and p.suffix.lower() in SAMPLE_FORMATS]
    elif samples.is_file():
        files = [samples]
    elif any(c in str(samples) for c in "*?["):
        files = [Path(p) for p in glob.glob(str(samples)) if Path(p).is_file()]
        if not files:
            raise ReadError(f"job {job.id!r}: {samples}: no file matches this pattern; check the folder and the '*'")
    else:
        raise ReadError(f"job {job.id!r}: {samples}: no such samples file or folder; check the path")
    return sorted({mesh, *files})


def job_hash(job):
    """A digest of everything a job's outputs depend on: equal hashes, equal outputs.

    SHA-256 over manifill's version, the job's command line (paths resolved) and the
    content of every input file (:func:`inputs`, read in 1 MiB blocks): an option or one
    byte of an input changes it, touching a file does not.

    Returns
    -------
    str
        64 hexadecimal digits.

    Raises
    ------
    ReadError
        An input is missing (as :func:`inputs`).
    """
    def resolved(p):
        return str(Path(os.path.expanduser(str(p))).resolve())

    argv = [job.command, resolved(job.mesh), resolved(job.samples), "-o", resolved(job.output),
            *with_paths(job.command, job.options, resolved)]
    h = hashlib.sha256(json.dumps(["manifill", version.__version__, argv]).encode())
    for path in inputs(job):
        one = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(_BLOCK), b""):
                one.update(block)
        h.update(json.dumps([str(path.resolve()), one.hexdigest()]).encode())
    return h.hexdigest()
