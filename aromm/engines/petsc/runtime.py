"""petsc4py/slepc4py/mpi4py imports and the few collective helpers the engine needs.

All collective helpers are called by every rank in the same order (SPMD); the results are identical on
every rank, so a check that fails fails everywhere and every rank raises the same error.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator
from types import ModuleType
from typing import Any

import numpy as np
import numpy.typing as npt

from aromm.engines import check_engine


def petsc() -> ModuleType:
    """The ``petsc4py.PETSc`` module (InputError with the install routes when absent)."""
    check_engine("petsc")
    from petsc4py import PETSc

    return PETSc


def slepc() -> ModuleType:
    """The ``slepc4py.SLEPc`` module."""
    check_engine("petsc")
    from slepc4py import SLEPc

    return SLEPc


def world() -> Any:
    """PETSc's world communicator (all ranks started by mpiexec)."""
    return petsc().COMM_WORLD


def mpi(comm: Any) -> Any:
    """The mpi4py communicator behind a PETSc one."""
    return comm.tompi4py()


def rank(comm: Any) -> int:
    return int(comm.getRank())


def size(comm: Any) -> int:
    return int(comm.getSize())


def is_root(comm: Any) -> bool:
    return rank(comm) == 0


@contextlib.contextmanager
def root_logs(comm: Any, *names: str) -> Iterator[None]:
    """While inside, the records below WARNING of the loggers ``names`` are dropped on every rank but 0: the serial
    code those loggers belong to runs unchanged on every rank (SPMD) and would say the same line once per rank."""

    def below_warning(record: logging.LogRecord) -> bool:
        return record.levelno >= logging.WARNING

    loggers = [logging.getLogger(name) for name in names] if not is_root(comm) else []
    for logger in loggers:
        logger.addFilter(below_warning)
    try:
        yield
    finally:
        for logger in loggers:
            logger.removeFilter(below_warning)


def allsum(values: npt.ArrayLike, comm: Any) -> np.ndarray:
    """Element-wise sum over the ranks (small arrays: Gram matrices, projected operators, face means)."""
    from mpi4py import MPI

    local = np.ascontiguousarray(np.asarray(values, dtype=float))
    total = np.empty_like(local)
    mpi(comm).Allreduce(local, total, op=MPI.SUM)
    return total


def allmax_array(values: npt.ArrayLike, comm: Any) -> np.ndarray:
    """Element-wise maximum over the ranks (per-stage peak memory)."""
    from mpi4py import MPI

    local = np.ascontiguousarray(np.asarray(values, dtype=float))
    total = np.empty_like(local)
    mpi(comm).Allreduce(local, total, op=MPI.MAX)
    return total


def allmax(value: float, comm: Any) -> float:
    from mpi4py import MPI

    return float(mpi(comm).allreduce(float(value), op=MPI.MAX))


def union(items: set[int], comm: Any) -> set[int]:
    """Union of small integer sets (labels present) over the ranks."""
    out: set[int] = set()
    for part in mpi(comm).allgather(sorted(items)):
        out.update(part)
    return out


def processors() -> tuple[int, int, int]:
    """Process-grid sizes fixed by the PETSc options ``-aromm_da_processors_x/y/z`` (0: not fixed)."""
    options = petsc().Options("aromm_da_")
    return (options.getInt("processors_x", 0), options.getInt("processors_y", 0), options.getInt("processors_z", 0))
