"""``manifill batch MANIFEST``: many ``reconstruct`` / ``volume`` jobs on a Dask cluster.

The ``batch`` subcommand lives here, in the cluster layer, not in :mod:`manifill.cli`: a batch runs
command lines, so the cluster layer uses the command line and not the other way round.
:mod:`manifill.cluster` adds this module to the command line's subcommands
(:func:`manifill.cli.main.add_command`) when it is imported, which the ``manifill`` command does first.
"""

import sys

from ..cli.options import check_workers
from .run import batch

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``manifill batch``."""
    s = sub.add_parser("batch", help="run the jobs of a manifest on this machine's cores or a Dask cluster",
                       description="Run every job of MANIFEST (CSV: columns mesh,samples,output and options; TOML: "
                                   "[[job]] tables) as its own 'manifill reconstruct' or 'manifill volume' command, "
                                   "on a local Dask cluster (one worker per core) or an existing one. Each job "
                                   "writes its outputs whole or not at all; the summary CSV gives every job's "
                                   "status, time, peak memory and error. A re-run skips the jobs already done "
                                   "with the same inputs and options.")
    s.add_argument("manifest", help="the jobs: .csv or .toml")
    s.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="an existing cluster's scheduler, e.g. tcp://10.0.0.1:8786 (default: $DASK_SCHEDULER_ADDRESS "
                        "if set, else a local cluster)")
    s.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    s.add_argument("--memory-limit", default=None, metavar="SIZE",
                   help="memory of each local worker, e.g. 4GB (default: the machine's memory shared among them)")
    s.add_argument("--summary", default=None, metavar="OUT.csv",
                   help="the summary CSV (default: MANIFEST's name with .summary.csv)")
    s.add_argument("--force", action="store_true", help="run every job again, even those already done")
    s.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    s.set_defaults(func=run)


def run(args):
    """``manifill batch MANIFEST``: exit 0 when every job is done (or was), 1 when some failed, 2 on bad input."""
    check_workers(args)

    def progress(row, finished, total):
        if not args.quiet:
            extra = f"  {row['error']}" if row["error"] else ""
            seconds = f" {float(row['seconds']):.1f} s" if row.get("seconds") else ""
            if row["status"] == "skipped":  # its time is the run that did it
                seconds = f" (done before in{seconds}, same inputs)" if seconds else " (done before, same inputs)"
            print(f"[{finished}/{total}] {row['id']}: {row['status']}{seconds}{extra}", flush=True)

    result = batch(args.manifest, scheduler=args.scheduler, workers=args.workers, memory_limit=args.memory_limit,
                   summary=args.summary, force=args.force, progress=progress)
    counts = ", ".join(f"{v} {k}" for k, v in sorted(result.counts().items()))
    if not args.quiet:
        where = f"on {result.workers} workers" if result.workers else "nothing to run"
        print(f"{len(result.rows)} jobs in {result.seconds:.1f} s, {where}: {counts}; summary {result.summary}")
    if not result.ok:
        bad = sum(r["status"] not in ("done", "skipped") for r in result.rows)
        print(f"manifill: {bad} of {len(result.rows)} jobs did not finish; their errors are in {result.summary}",
              file=sys.stderr)
        return 1
    return 0
