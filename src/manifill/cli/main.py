"""The ``manifill`` command line: a thin shell over the library.

Subcommands: ``info`` (what is in a mesh), ``check`` (the gradual variation
condition of samples), ``reconstruct`` (the paper's pipeline), ``cv`` (which method to trust), ``harmonic`` (fill a
field from the samples alone), ``volume`` (Steps 1-8 inside a solid), ``batch`` (many jobs on a Dask
cluster), ``demo`` (the built-in example). Bad input ends with exit code 2 and one line
``manifill: error: ...`` on standard error, never a traceback; nothing is left
half-written.

``batch`` is defined above the command line, in :mod:`manifill.cluster.command` (a batch runs
command lines): :mod:`manifill.cluster` adds it with :func:`add_command` when imported, and
``import manifill`` (which any import of ``manifill.cli`` runs first) imports it. This module
never imports the cluster layer.
"""

import argparse
import contextlib
import io
import shlex
import logging
import os
import signal
import sys
import threading

from ..version import __version__
from ..errors import ManifillError
from . import check, cv, demo, globe, harmonic, info, reconstruct, volume
from ..io.files import remove_active_temporaries
from .common import err

__all__ = ["main", "build_parser", "add_command", "COMMANDS"]

#: one module per subcommand, in the order of the help; a layer above adds its own (:func:`add_command`)
COMMANDS = [info, harmonic, check, reconstruct, cv, volume, globe, demo]


def add_command(module, before=None):
    """Add a subcommand defined above the command line (``batch``, by :mod:`manifill.cluster`).

    Parameters
    ----------
    module : module
        Has ``add_parser(sub)``, which adds the subcommand's parser and sets its ``func``.
    before : str, optional
        The name of the subcommand module it comes before in the help (last when None or absent).
        Adding a module again changes nothing.
    """
    if module in COMMANDS:
        return
    names = [m.__name__.rsplit(".", 1)[-1] for m in COMMANDS]
    COMMANDS.insert(names.index(before) if before in names else len(COMMANDS), module)


class _Parser(argparse.ArgumentParser):
    """argparse with manifill's one-line errors (exit status 2)."""

    def error(self, message):
        self.exit(2, f"manifill: error: {message} (see '{self.prog} --help')\n")


def build_parser():
    """The argument parser (exposed for documentation and tests)."""
    p = _Parser(
        prog="manifill",
        description="Reconstruct a smooth field over a surface from a few sample values, without changing the mesh.",
    )
    p.add_argument("--version", action="version", version=f"manifill {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for command in COMMANDS:
        command.add_parser(sub)
    return p


def main(argv=None):
    """Run the command line.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    int
        0 on success, 2 on bad input (argparse's usage errors included).
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    args.command_line = " ".join(shlex.quote(str(a)) for a in ["manifill", *(sys.argv[1:] if argv is None else argv)])
    with _terminate_as_interrupt():
        try:
            if getattr(args, "quiet", False):
                with contextlib.redirect_stdout(io.StringIO()):
                    return args.func(args)
            return args.func(args)
        except BrokenPipeError:
            # the reader went away (e.g. `manifill info --json m.ply | head`): stop quietly
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 1
        except _Terminated:
            print("manifill: terminated; no output was left half-written", file=sys.stderr)
            _quiet_shutdown(argv)
            return 143
        except KeyboardInterrupt:
            print("manifill: interrupted; no output was left half-written", file=sys.stderr)
            _quiet_shutdown(argv)
            return 130
        except ManifillError as exc:
            return err(str(exc))
        except ImportError as exc:
            return err(str(exc).splitlines()[0])
        except MemoryError:
            return err("out of memory during the computation; try a smaller mesh, a lower resolution or solver='amg'")
        except OSError as exc:
            return err(f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))
        except Exception as exc:  # noqa: BLE001 - a bug of manifill's: one line, the traceback on request
            if os.environ.get("MANIFILL_DEBUG"):
                raise
            text = " ".join(str(exc).split())[:200]
            print(f"manifill: internal error: {type(exc).__name__}: {text} (a bug; MANIFILL_DEBUG=1 shows the "
                  f"traceback)", file=sys.stderr)
            return 1


def _quiet_shutdown(argv):
    """After the one line of a signal, nothing more: a Dask cluster cut short while it started prints tracebacks
    from its exit handlers and event loop (``Nanny failed to start``). Only for the command line itself
    (``argv`` None): a program calling :func:`main` keeps its own hooks."""
    if argv is not None:
        return
    sys.unraisablehook = lambda unraisable: None  # "Exception ignored in atexit callback"
    for name in ("asyncio", "distributed", "tornado"):  # "Task exception was never retrieved"
        logging.getLogger(name).disabled = True


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is so that temporary files are removed on the way out."""


@contextlib.contextmanager
def _terminate_as_interrupt():
    """While the command runs, SIGTERM unwinds like Ctrl-C (only in the main thread, where signals arrive)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    handled = threading.Event()  # the main thread has begun to unwind: the watchdog stands down

    def raise_terminated(signum, frame):
        handled.set()
        raise _Terminated()

    def raise_interrupt(signum, frame):
        handled.set()
        raise KeyboardInterrupt()

    previous = signal.signal(signal.SIGTERM, raise_terminated)
    previous_int = signal.getsignal(signal.SIGINT)
    if previous_int is signal.default_int_handler:  # left alone when ignored (a background job) or a host's own
        signal.signal(signal.SIGINT, raise_interrupt)
    try:
        watchdog = _Watchdog(handled)
    except (OSError, RuntimeError, ValueError):  # no pipe or thread to spare: signals as Python handles them
        watchdog = None
    try:
        yield
    finally:
        if watchdog is not None:
            watchdog.stop()
        signal.signal(signal.SIGTERM, previous)
        if previous_int is signal.default_int_handler:
            signal.signal(signal.SIGINT, previous_int)


#: Seconds a signal may wait for the main thread (busy in one long call of a compiled solver) before the
#: watchdog stops the process itself.
GRACE_SECONDS = 3.0


class _Watchdog:
    """Honours SIGTERM and Ctrl-C within :data:`GRACE_SECONDS` even while the main thread is inside one long
    compiled call (a factorisation, a dense eigen-solve: Python runs its handlers only between calls, and a gp
    took 43 s to stop): the signal's number arrives on a pipe (``signal.set_wakeup_fd``) that a thread watches;
    if the main thread has not begun to unwind by then (its handler sets ``handled``; a long clean-up after that
    is left to run), the thread removes the temporaries of the writes under way, says so in one line and ends
    the process (exit 143 or 130)."""

    def __init__(self, handled):
        self._handled = handled
        self._read, self._write = os.pipe()
        os.set_blocking(self._write, False)
        self._done = threading.Event()
        self._previous = signal.set_wakeup_fd(self._write, warn_on_full_buffer=False)
        self._thread = threading.Thread(target=self._watch, name="manifill-signal-watchdog", daemon=True)
        self._thread.start()

    def _watch(self):
        while not self._done.is_set():
            try:
                got = os.read(self._read, 64)
            except OSError:
                return
            wanted = [s for s in got if s in (signal.SIGTERM, signal.SIGINT)]
            if self._done.is_set() or not wanted:
                continue
            if self._handled.wait(GRACE_SECONDS) or self._done.is_set():  # the main thread unwinds: its own way
                return
            remove_active_temporaries()
            what = "terminated" if wanted[0] == signal.SIGTERM else "interrupted"
            os.write(2, f"manifill: {what} inside a solver's call that cannot be interrupted; stopped it, no "
                        f"output was left half-written\n".encode())
            os._exit(143 if wanted[0] == signal.SIGTERM else 130)

    def stop(self):
        self._done.set()
        signal.set_wakeup_fd(self._previous)
        try:
            os.write(self._write, b"\0")  # wakes the thread, which sees it is done
        except OSError:
            pass
        self._thread.join(timeout=1.0)
        for fd in (self._read, self._write):
            os.close(fd)
