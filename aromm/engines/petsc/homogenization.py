"""Homogenisation probes [Chavez2020, eq. 13–14] on the petsc engine.

The formulas are those of :mod:`aromm.homogenization.properties`
(:func:`aromm.homogenization.properties.conductivity` runs the three
probes); this module supplies the distributed steady solve of one probe and the volume-averaged capacity,
counted box by box (for a voxel image the Q1 phase mass ``1ᵀ C_p 1`` is exactly the phase's volume).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from aromm.core.errors import InputError
from aromm.engines.petsc import linear, runtime
from aromm.engines.petsc.assembly import assemble_boxes
from aromm.engines.petsc.problem import VoxelProblem
from aromm.engines.petsc.steady import steady
from aromm.homogenization.properties import ProbeSolver
from aromm.scene.scene_file import Scene


def as_problem(scene: Scene | VoxelProblem) -> VoxelProblem:
    """The thermal problem of a probe: a ``[moisture]`` scene's probes of eq. 13 are thermal (its moisture transport
    is homogenised by :mod:`aromm.homogenization.moisture_cells`, scipy engine)."""
    if isinstance(scene, VoxelProblem):
        return replace(scene, moisture=None)
    return VoxelProblem.from_scene(replace(scene, moisture=None))


def probe_solver(solver: str = "gamg", comm: Any = None) -> ProbeSolver:
    """A :data:`aromm.homogenization.ProbeSolver` solving each probe by boxes (collective)."""
    solver = linear.check_solver(solver)
    comm = comm if comm is not None else runtime.world()

    def solve(probe: Any) -> tuple[dict[str, float], float]:
        state = steady(assemble_boxes(as_problem(probe), comm), solver=solver)
        return state.means, next(iter(state.heat_flow.values()), 0.0)

    return solve


def mean_capacity(problem: VoxelProblem, comm: Any = None) -> float:
    """Volume-averaged capacity ``c̄ = Σ c_p |Ω_p| / |Ω|`` (J/(m³ K)), eq. 14, from the voxel counts of the boxes."""
    comm = comm if comm is not None else runtime.world()
    missing = [ph.name for ph in problem.phases if ph.c is None]
    if missing:
        raise InputError(f"{problem.where}mean capacity needs c for every phase; missing for {missing}")
    labels = problem.image.read(problem.layout(comm).box)
    counts = runtime.allsum([np.count_nonzero(labels == ph.label) for ph in problem.phases], comm)
    return float(sum(n * float(ph.c) for n, ph in zip(counts, problem.phases, strict=True) if ph.c is not None)
                 / counts.sum())
