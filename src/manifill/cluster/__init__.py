"""Batches: many jobs (meshes, samples, options) run on a Dask cluster, or on this machine's cores.

A job is one ``manifill reconstruct`` or ``manifill volume`` command line; a batch is a list
of them, from a manifest (CSV or TOML, :mod:`manifill.cluster.manifest`) or from Python.
:func:`batch` (:mod:`manifill.cluster.run`) hands them to ``dask.distributed``: a
``LocalCluster`` with one worker process per core by default, or an existing cluster by its
scheduler's address. Each job runs in-process on a worker exactly as the command line would
(the same options, checks and one-line errors), writes its outputs atomically, and gets one
row in the batch's summary CSV; a re-run skips the jobs whose inputs, options and outputs are
unchanged. manifill schedules nothing itself: Dask does, and retries a job whose worker died.

``dask`` and ``distributed`` are the optional ``[batch]`` extra, imported when a batch runs.

The layer sits above the command line and uses it (a job is a command line): the ``batch``
subcommand is :mod:`manifill.cluster.command`, added here to the command line's subcommands
(:func:`manifill.cli.main.add_command`); :mod:`manifill.cli` never imports this layer: the ``manifill`` command
(:mod:`manifill.console`) imports it first, and ``manifill.batch`` loads it on first use.
"""

from ..cli.main import add_command
from ..io.distributed import EXTRA
from . import command
from .run import BatchResult, batch, need_distributed

__all__ = ["batch", "BatchResult", "need_distributed", "EXTRA"]

add_command(command, before="demo")  # `manifill batch`: the command line never imports this layer
