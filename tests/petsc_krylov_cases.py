"""Cases of the krylov-on-petsc tests (method="krylov", engine="petsc": KSP solves only), computed the same way
by the serial scipy engine (CHOLMOD), by the petsc engine at 1 rank (in the pytest process) and under
``mpiexec`` at 2 ranks and at 4 ranks cut 2×2×1 (``petsc_worker.py OUT petsc_krylov_cases``).

The random two-phase image and its scenario are those of :mod:`petsc_cases` (contrast 12 in k, 3300 in c); the
greedy runs 3 parameter points over the box, 4 shifts, 2 moments each.  The runs:

* ``compressed_mumps``: shifted solves by MUMPS (exact to round-off, as CHOLMOD): the engines' algebra
  (moments, orthonormalisation, projection, residual indicator and so the greedy's points) against the serial
  engine's, the span compressed to order 40 (gramian), where the compression loss is ≈ 1e-6 °C and the kept
  directions are well separated from the dropped ones;
* ``span_gamg``: the span model with CG + GAMG solves to a relative residual of 1e-12;
* ``span_auto``: the span model on an 8×8×16 image, whose node grid halves twice on every rank up to 2 ranks
  (z-slabs): CG preconditioned by geometric multigrid on the DMDA (the ``"auto"`` choice there; GAMG in 2×2×1
  boxes, whose ranks own too few nodes), to 1e-12.

Every run keeps a moment vector only when its part outside the basis exceeds :data:`DROP` of its C-norm (the
reductor's default, ``aromm.reduction.krylov.DROP = 1e-10``, also keeps directions that are round-off: the serial engine
alone, CHOLMOD against SuperLU, then differs by 1.4e-7 °C at the slow corner; with 1e-7 by 8e-11 °C).
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from petsc_cases import PHASES, PROBE, SCENARIO, labels

import aromm
import aromm.reduction.krylov
from aromm.core.system import TimeGrid
from aromm.reduction.krylov import KrylovReductor
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, assemble

BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1.0e6, 1.0e7)}
#: Where the models are compared: away from the box's centre, and at its slow corner.
POINTS = (PROBE, {"fibre.k": 0.1, "fibre.c": 1.0e7})
#: name → (image shape, order, petsc solver, relative residual of the petsc engine's shifted solves).
RUNS = {"compressed_mumps": ((8, 9, 10), 40, "mumps", 1e-12),
        "span_gamg": ((8, 9, 10), 200, "gamg", 1e-12), "span_auto": ((8, 8, 16), 200, "auto", 1e-12)}
#: The certified run (:func:`certified`): image shape, order (low, so that the bound is well above rounding), solver.
CERTIFIED = ((8, 9, 10), 8, "gamg")
#: The serial engine's solves (CHOLMOD, exact to round-off; it checks its residual against this).
SERIAL_RTOL = 1e-12
#: Relative size of a moment vector's new part below which it adds no direction (module docstring).
DROP = 1e-7


@contextmanager
def dropping(drop: float) -> Iterator[None]:
    """The reductor's drop threshold set to ``drop`` for the runs inside, restored after."""
    kept = aromm.reduction.krylov.DROP
    aromm.reduction.krylov.DROP = drop
    try:
        yield
    finally:
        aromm.reduction.krylov.DROP = kept


def scene(shape: tuple[int, int, int]) -> Scene:
    """A random two-phase image of ``shape`` voxels (at most 1,377 nodes), outputs every 0.2 s to 2 s."""
    return Scene(VoxelGeometry(labels(shape, 3), (1e-4, 1e-4, 1e-4)), PHASES, SCENARIO, 0.0, TimeGrid(2.0, 0.2),
                 ("z0", "z1"))


def reductor(rtol: float) -> KrylovReductor:
    return KrylovReductor.over(BOX, max_points=3, shifts=4, rtol=rtol)


def _record(rom: aromm.ReducedModel, name: str) -> dict[str, np.ndarray]:
    """Face means at the output times at every comparison point, the span's size and the linear solver."""
    return {name: np.stack([rom.simulate(p).as_array() for p in POINTS]),
            f"{name}_span": np.array([rom.info["krylov_span"], rom.info["krylov_points"], rom.order]),
            f"{name}_solver": np.array(str(rom.info["solver"]))}


@contextmanager
def krylov_lines() -> Iterator[list[str]]:
    """The ``krylov:`` INFO lines this process logs inside (aromm.reduction.krylov's logger)."""
    said: list[str] = []
    handler = logging.Handler(logging.INFO)
    handler.emit = lambda record: said.append(record.getMessage())  # type: ignore[method-assign]
    logger = logging.getLogger(aromm.reduction.krylov.__name__)
    level = logger.level
    logger.setLevel(logging.INFO)
    logger.addHandler(handler)
    try:
        yield said
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def results(comm: Any) -> dict[str, np.ndarray]:
    """The runs of :data:`RUNS` on the petsc engine (collective), whether SLEPc was loaded, and the number of
    ``krylov:`` log lines of each rank."""
    from aromm.engines.petsc import runtime

    out: dict[str, np.ndarray] = {}
    with krylov_lines() as said:
        for name, (shape, order, solver, rtol) in RUNS.items():
            with dropping(DROP):
                rom = aromm.reduce(scene(shape), order, method=reductor(rtol), engine="petsc", solver=solver,
                                   cache=False)
            out |= _record(rom, name)
    out |= certified("petsc")
    out["slepc_loaded"] = np.array("slepc4py.SLEPc" in sys.modules)
    out["krylov_log_lines"] = np.array(runtime.mpi(comm).allgather(sum(s.startswith("krylov:") for s in said)))
    return out


def certified(engine: str) -> dict[str, np.ndarray]:
    """The model of :data:`CERTIFIED` built with its certificate on ``engine`` (the petsc engine's shifted solves by
    CG + GAMG to 1e-12, the Gram matrices' too): face means and certified bounds at :data:`POINTS`."""
    shape, order, solver = CERTIFIED
    source = scene(shape) if engine == "petsc" else assemble(scene(shape))
    reductor = KrylovReductor.over(BOX, max_points=3, shifts=4, rtol=1e-12, certify=True)
    options = {"engine": "petsc", "solver": solver} if engine == "petsc" else {}
    with dropping(DROP):
        rom = aromm.reduce(source, order, method=reductor, cache=False, **options)
    bounds = [rom.error_bound(p) for p in POINTS]
    return {"certified": np.stack([rom.simulate(p).as_array() for p in POINTS]),
            "certified_bound": np.stack([b if b is not None else np.full(2, np.nan) for b in bounds]),
            "certified_order": np.array(rom.order)}


def serial() -> dict[str, np.ndarray]:
    """The same runs on the serial scipy engine."""
    out: dict[str, np.ndarray] = certified("scipy")
    for name, (shape, order, _, _) in RUNS.items():
        with dropping(DROP):
            rom = aromm.reduce(assemble(scene(shape)), order, method=reductor(SERIAL_RTOL), cache=False)
        out |= _record(rom, name)
    return out
