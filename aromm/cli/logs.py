"""Progress and notes of the commands in the log (issue 23 item 5): what the bars show on a terminal also reaches a
file when stderr is redirected (``aromm reduce scene.toml 2> build.log``, a batch job).

The library reports through :mod:`logging` (loggers ``aromm.*`` and ``inverse.*``: a line per stage of a build,
per 10 % of the pairs of each eigen-solve, the cache entries used, the conversions of a laboratory CSV).  The
command line sends those records to stderr as ``aromm: [  12.3 s] message`` (elapsed wall time since the command
started): every INFO record when stderr is not a terminal; on a terminal, where the bars show the progress,
only the notes of the CSV reader (:mod:`aromm.core.labcsv`), an automatic time grid's reason
(:mod:`aromm.scene.time_section`), a direction without a conducting path (:mod:`aromm.homogenization.fv_cells`,
and :mod:`aromm.homogenization.fv_periodic`, which also says when a periodic cell falls back to the assembled
operator), the finite-volume kernels running without numba (:mod:`aromm.fv.kernels`) and warnings.
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

LOGGERS = ("aromm", "inverse")
# always shown: what the reader converted or dropped, an automatic time grid, a direction without a conducting path,
# finite-volume kernels running in numpy for want of numba
NOTES = ("aromm.core.labcsv", "aromm.scene.time_section", "aromm.homogenization.fv_cells",
         "aromm.homogenization.fv_periodic", "aromm.fv.kernels")


class Elapsed(logging.Formatter):
    """``aromm: [  12.3 s] message``: seconds of wall time since the command started."""

    def __init__(self) -> None:
        super().__init__()
        self.start = time.perf_counter()

    def format(self, record: logging.LogRecord) -> str:
        return f"aromm: [{time.perf_counter() - self.start:7.1f} s] {record.getMessage()}"


def _terminal_filter(record: logging.LogRecord) -> bool:
    return record.levelno >= logging.WARNING or record.name.startswith(NOTES)


@contextmanager
def command_logs() -> Iterator[logging.Handler]:
    """Within the block, the toolkit's log records go to the current ``sys.stderr`` (module docstring)."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(Elapsed())
    if sys.stderr.isatty():
        handler.addFilter(_terminal_filter)
    loggers = [logging.getLogger(name) for name in LOGGERS]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.addHandler(handler)
        lg.setLevel(logging.INFO)
    try:
        yield handler
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.removeHandler(handler)
            lg.setLevel(level)
