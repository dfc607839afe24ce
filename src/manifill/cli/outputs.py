"""Outputs of a command checked before any work: extensions, folders, writability, no output over an input."""

import os
import tempfile
from pathlib import Path

from ..errors import WriteError

__all__ = ["check_outputs"]


def _same(a, b):
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _writable(folder):
    """Whether a file can be created in ``folder`` (tried, since permissions alone do not tell)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".manifill-probe-", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(probe)
    return True


def check_outputs(outputs, inputs):
    """Check every output of a command before any work.

    Parameters
    ----------
    outputs : list of (str, str or None, tuple of str)
        ``(option, path, allowed extensions)``; a None path is skipped.
    inputs : list of str
        Input paths no output may overwrite.

    Returns
    -------
    list of Path
        The outputs (None where not given), in order.

    Raises
    ------
    WriteError
        A wrong extension, a missing or read-only folder, an output equal to an
        input or to another output.
    """
    seen, result = [], []
    ins = [Path(p).resolve() for p in inputs if p]
    for option, path, allowed in outputs:
        if path is None:
            result.append(None)
            continue
        out = Path(path)
        if out.suffix.lower() not in allowed:
            raise WriteError(f"{out.name}: {option} writes {', '.join(allowed)}; change the name")
        if not out.parent.is_dir():
            raise WriteError(f"folder {out.parent} does not exist; create it first or choose another path for "
                             f"{option}")
        if out.is_dir():
            raise WriteError(f"{out} is a folder; give {option} a file name")
        resolved = out.resolve()
        for src in ins:
            if resolved == src or _same(out, src):
                raise WriteError(f"{option} {out.name} is also an input; write to another file")
        for other, opt in seen:
            if resolved == other:
                raise WriteError(f"{option} and {opt} both write {out.name}; give them different names")
        if not _writable(out.parent):
            raise WriteError(f"folder {out.parent} is not writable; choose another path for {option}")
        seen.append((resolved, option))
        result.append(out)
    return result
