"""Homogenisation probes [Chavez2020, eq. 13–14] on the petsc engine.

The formulas are those of :mod:`aromm.homogenization.properties`
(:func:`aromm.homogenization.properties.conductivity` runs the three
probes); this module supplies the distributed steady solve of one probe and the volume-averaged capacity,
counted box by box (for a voxel image the Q1 phase mass ``1ᵀ C_p 1`` is exactly the phase's volume).

A ``[moisture]`` scene: its thermal probes leave the moisture out (:func:`as_problem`); :func:`moisture_transport` is
the fixed-value or the flux probe of :func:`aromm.homogenization.moisture_cells.moisture_transport` (the same probes
and formulas, :func:`aromm.homogenization.moisture_cells.fixed_value_transport` and ``flux_probe_transport``) with
distributed coupled steady solves, and :func:`mean_moisture_capacity` its ξ̄ by boxes.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.engines.petsc import linear, runtime
from aromm.engines.petsc.assembly import assemble_boxes
from aromm.engines.petsc.problem import VoxelProblem
from aromm.engines.petsc.steady import steady
from aromm.homogenization.moisture_cells import (
    ProbeSolve,
    fixed_value_transport,
    flux_probe_transport,
    require_moisture,
)
from aromm.homogenization.properties import ProbeSolver
from aromm.scene.scene_file import Scene

#: The probes of the moisture transport the petsc engine solves (the periodic cell is the scipy engine's).
MOISTURE_PROBES = ("temperature", "flux")


def as_problem(scene: Scene | VoxelProblem) -> VoxelProblem:
    """The thermal problem of a probe: a ``[moisture]`` scene's probes of eq. 13 are thermal (its moisture transport:
    :func:`moisture_transport`)."""
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
    missing = [ph.name for ph in problem.phases if ph.c is None]
    if missing:
        raise InputError(f"{problem.where}mean capacity needs c for every phase; missing for {missing}")
    return _volume_average(problem, [float(ph.c) for ph in problem.phases if ph.c is not None], comm)


def moisture_transport(scene: Scene | VoxelProblem, boundary: str = "temperature", solver: str = "gamg",
                       comm: Any = None) -> FloatArray:
    """(3, 2, 2): per axis the effective heat and moisture flux matrix (W/m², kg/(m² s)) of a ``[moisture]`` scene by
    the fixed-value probe (``temperature``) or the flux probe (``flux``), as ``moisture_transport(scene, boundary)`` of
    :mod:`aromm.homogenization.moisture_cells` (the same probes and formulas), each coupled steady solve by boxes
    (collective)."""
    if boundary not in MOISTURE_PROBES:
        raise InputError(f"{getattr(scene, 'where', '')}moisture transport: the petsc engine homogenises it by the "
                         f"probes {' or '.join(MOISTURE_PROBES)}, got {boundary!r} (the periodic cell: --engine scipy)")
    solver = linear.check_solver(solver)
    comm = comm if comm is not None else runtime.world()
    problem = scene if isinstance(scene, VoxelProblem) else VoxelProblem.from_scene(scene)

    def prepare(probe: VoxelProblem) -> ProbeSolve:
        system = assemble_boxes(probe, comm)
        param = {d.name: d.param for d in system.template.dirichlet}

        def solve(values: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
            state = steady(system, values, solver=solver)
            return state.means, {param[name]: flow for name, flow in state.heat_flow.items()}

        return solve

    transport = fixed_value_transport if boundary == "temperature" else flux_probe_transport
    return transport(problem, prepare)


def mean_moisture_capacity(problem: VoxelProblem, comm: Any = None) -> float:
    """ξ̄ (kg/m³): the volume average of the phases' ξ, from the voxel counts of the boxes (collective)."""
    phases = require_moisture(problem).phases
    return _volume_average(problem, [phases[ph.name]["xi"] for ph in problem.phases], comm)


def _volume_average(problem: VoxelProblem, values: list[float], comm: Any) -> float:
    """``Σ v_p |Ω_p| / |Ω|`` of one value per phase of ``problem`` (collective)."""
    comm = comm if comm is not None else runtime.world()
    labels = problem.image.read(problem.layout(comm).box)
    counts = runtime.allsum([np.count_nonzero(labels == ph.label) for ph in problem.phases], comm)
    return float(sum(n * v for n, v in zip(counts, values, strict=True)) / counts.sum())
