"""A task farm for many independent runs: repeated identifications (noisy repetitions, bootstrap, seeds),
parameter and accuracy-against-cost sweeps.

One option selects where the tasks run (:data:`FARMS`):

* ``"serial"``: one after the other in this process (the reference);
* ``"processes"``: a pool of worker processes on this machine (``concurrent.futures.ProcessPoolExecutor``,
  started by ``spawn``: no state inherited from the parent);
* ``"mpi"``: ``mpi4py.futures.MPIPoolExecutor`` on a cluster, the workers being MPI ranks — run the script as
  ``mpiexec -n P python -m mpi4py.futures script.py`` (rank 0 runs the script, P − 1 ranks work).

:meth:`Farm.map` returns the results in the order of the tasks.  Every task carries its own seed (no global
RNG) and every worker limits BLAS to one thread, as the reduced model does in this process, so the results
are identical to the serial run's, bit for bit (tests/test_farm.py).  Tasks and results travel by pickle: the
function must be defined at module level and its arguments picklable.  What every task reads (a reduced model,
the measurements) goes as ``shared``: it travels once per worker, in the worker's initialiser, not with every
task, and the function is called as ``fn(shared, task)``.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass
from functools import partial
from typing import Any, TypeVar

from aromm.core.errors import InputError

FARMS = ("serial", "processes", "mpi")

T = TypeVar("T")
R = TypeVar("R")


#: What the tasks of the running map share, set in each worker by its initialiser (None in the parent).
_shared: Any = None


def _start_worker(shared: Any = None) -> None:
    """Worker initialiser: one BLAS thread per worker process (the workers share the cores), and the object the
    tasks share, received once."""
    from threadpoolctl import threadpool_limits

    global _shared  # noqa: PLW0603  (the worker's one copy of what its tasks share)
    threadpool_limits(limits=1, user_api="blas")
    _shared = shared


def _with_shared(fn: Callable[[Any, T], R], task: T) -> R:
    return fn(_shared, task)


@dataclass(frozen=True)
class Farm:
    """Where independent tasks run: ``kind`` in :data:`FARMS`, ``workers`` processes (None: the executor's
    default, the CPU count or the MPI universe)."""

    kind: str = "serial"
    workers: int | None = None

    def __post_init__(self) -> None:
        if self.kind not in FARMS:
            raise InputError(f"unknown task farm {self.kind!r}; allowed: {', '.join(FARMS)}")
        if self.workers is not None and self.workers < 1:
            raise InputError(f"a task farm needs at least one worker, got {self.workers}")

    def executor(self, shared: Any = None) -> Executor:
        """The pool; each worker starts with one BLAS thread and its copy of ``shared``."""
        if self.kind == "mpi":
            try:
                from mpi4py.futures import MPIPoolExecutor
            except ImportError:
                raise InputError("task farm 'mpi' needs mpi4py (README 'Running on a cluster'); use 'processes' "
                                 "on one machine") from None
            return MPIPoolExecutor(max_workers=self.workers, initializer=_start_worker, initargs=(shared,))
        return ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_start_worker, initargs=(shared,))

    def map(self, fn: Callable[[T], R], tasks: Iterable[T]) -> list[R]:
        """``[fn(t) for t in tasks]``, the tasks spread over the farm; results in the order of the tasks."""
        items = list(tasks)
        if self.kind == "serial" or len(items) <= 1:
            return [fn(t) for t in items]
        with self.executor() as pool:
            return list(pool.map(fn, items))

    def map_shared(self, fn: Callable[[Any, T], R], shared: Any, tasks: Iterable[T]) -> list[R]:
        """``[fn(shared, t) for t in tasks]``, ``shared`` sent once to each worker (not with every task)."""
        items = list(tasks)
        if self.kind == "serial" or len(items) <= 1:
            return [fn(shared, t) for t in items]
        with self.executor(shared) as pool:
            return list(pool.map(partial(_with_shared, fn), items))
