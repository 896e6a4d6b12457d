"""Global search by particle swarm [Chavez2020, § 4.1], through pyswarms' backend, random draws our own.

Global-best PSO (Star topology) with the constriction coefficients w = 0.7298, c1 = c2 = 1.49618
[ClercKennedy2002], velocities clamped to ±0.5 of the range per step and reflective boundaries, in the
normalised coordinates of :class:`~inverse.optimisers.box.Box`.  Each iteration is

    v ← w v + c1 r1 (p_best − x) + c2 r2 (g_best − x),   x ← x + v   (reflected into [0, 1]^p),

with r1, r2 uniform on [0, 1) drawn from the swarm's own ``numpy.random.Generator`` (its state is part of
the swarm state, so a checkpoint resumes the run exactly).  pyswarms (the product's chosen library)
supplies the topology (global best), the personal-best update and the velocity and boundary handlers;
only the velocity formula is written here, because pyswarms draws r1, r2 from numpy's global legacy RNG,
which a library must not touch.  Importing pyswarms and building its objects reconfigures the root
logger and writes ``report.log`` in the working directory; :func:`_contained` prevents it (pyswarms'
``Reporter`` reads a logging configuration from ``$LOG_CFG`` first: an empty incremental one is a no-op).
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from inverse.optimisers.interface import Objective, Outcome, Problem, State, Step

W, C1, C2 = 0.7298, 1.49618, 1.49618  # Clerc–Kennedy constriction [ClercKennedy2002]
V_MAX = 0.5  # velocity clamp, fraction of the normalised range per step


@contextmanager
def _contained() -> Iterator[None]:
    """Let pyswarms import and build its objects without reconfiguring logging (see module doc)."""
    with tempfile.TemporaryDirectory(prefix="aromm-pyswarms-") as tmp:
        cfg = Path(tmp) / "logging.yml"
        cfg.write_text("version: 1\nincremental: true\n", encoding="utf-8")
        previous = os.environ.get("LOG_CFG")
        os.environ["LOG_CFG"] = str(cfg)
        try:
            yield
        finally:
            if previous is None:
                del os.environ["LOG_CFG"]
            else:
                os.environ["LOG_CFG"] = previous


@dataclass(frozen=True)
class _Backend:
    """The pyswarms backend pieces one swarm step uses, built under :func:`_contained`."""

    swarm: Any
    topology: Any
    boundary: Any
    velocity: Any
    compute_pbest: Any
    compute_position: Any

    @classmethod
    def build(cls) -> _Backend:
        with _contained():
            from pyswarms.backend.handlers import BoundaryHandler, VelocityHandler
            from pyswarms.backend.operators import compute_pbest, compute_position
            from pyswarms.backend.swarms import Swarm
            from pyswarms.backend.topology import Star

            return cls(Swarm, Star(), BoundaryHandler(strategy="reflective"),
                       VelocityHandler(strategy="unmodified"), compute_pbest, compute_position)


def _generator_state(rng: np.random.Generator) -> np.ndarray:
    return np.asarray(json.dumps(rng.bit_generator.state))


def _generator(state: np.ndarray) -> np.random.Generator:
    saved = json.loads(str(state))
    bits = getattr(np.random, saved["bit_generator"])()
    bits.state = saved
    return np.random.Generator(bits)


@dataclass(frozen=True)
class SwarmState:
    """Everything needed to continue a swarm exactly (checkpoints): positions in ``[0,1]^p`` and the
    swarm's own random generator."""

    iteration: int
    position: FloatArray
    velocity: FloatArray
    pbest_pos: FloatArray
    pbest_cost: FloatArray
    rng: np.random.Generator

    @property
    def best_index(self) -> int:
        return int(np.argmin(self.pbest_cost))

    @property
    def best_pos(self) -> FloatArray:
        return np.asarray(self.pbest_pos[self.best_index])

    @property
    def best_cost(self) -> float:
        return float(self.pbest_cost[self.best_index])

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {"iteration": np.asarray(self.iteration), "position": self.position, "velocity": self.velocity,
                "pbest_pos": self.pbest_pos, "pbest_cost": self.pbest_cost, "rng": _generator_state(self.rng)}

    @classmethod
    def from_arrays(cls, a: Mapping[str, np.ndarray]) -> SwarmState:
        missing = sorted({"iteration", "position", "velocity", "pbest_pos", "pbest_cost", "rng"} - set(a))
        if missing:
            raise InputError(f"swarm state lacks {missing} (a checkpoint of another format?)")
        return cls(int(a["iteration"]), np.array(a["position"]), np.array(a["velocity"]), np.array(a["pbest_pos"]),
                   np.array(a["pbest_cost"]), _generator(a["rng"]))


def swarm_start(objective: Objective, dim: int, particles: int, rng: np.random.Generator) -> SwarmState:
    """Uniform random particles in ``[0,1]^dim``, velocities ``(U - x)/2``, evaluated once (iteration 0).

    The swarm's own generator is spawned from ``rng``.
    """
    if particles < 2:
        raise InputError(f"PSO needs at least 2 particles, got {particles}")
    x = rng.random((particles, dim))
    v = 0.5 * (rng.random((particles, dim)) - x)
    return SwarmState(0, x, v, x.copy(), objective(x), rng.spawn(1)[0])


def swarm_step(state: SwarmState, objective: Objective, backend: _Backend | None = None) -> SwarmState:
    """One global-best PSO iteration: move (velocity formula above, pyswarms' handlers), evaluate, update bests."""
    dim = state.position.shape[1]
    bounds = (np.zeros(dim), np.ones(dim))
    ps = backend if backend is not None else _Backend.build()
    swarm = ps.swarm(state.position.copy(), state.velocity.copy(), options={"w": W, "c1": C1, "c2": C2},
                     pbest_pos=state.pbest_pos.copy(), pbest_cost=state.pbest_cost.copy())
    swarm.best_pos, swarm.best_cost = ps.topology.compute_gbest(swarm)
    rng = _generator(_generator_state(state.rng))  # a copy: the given state is never advanced
    r1, r2 = rng.random((2, *swarm.position.shape))
    velocity = W * swarm.velocity + C1 * r1 * (swarm.pbest_pos - swarm.position) \
        + C2 * r2 * (swarm.best_pos - swarm.position)
    swarm.velocity = ps.velocity(velocity, (-V_MAX, V_MAX), position=swarm.position, bounds=bounds)
    swarm.position = np.clip(ps.compute_position(swarm, bounds, ps.boundary), 0.0, 1.0)
    swarm.current_cost = objective(swarm.position)
    pbest_pos, pbest_cost = ps.compute_pbest(swarm)
    return SwarmState(state.iteration + 1, swarm.position, swarm.velocity, np.asarray(pbest_pos),
                      np.asarray(pbest_cost, dtype=float), rng)


def pso(objective: Objective, dim: int, rng: np.random.Generator, *, particles: int = 20, iterations: int = 30,
        state: SwarmState | None = None, callback: Callable[[SwarmState], None] | None = None) -> SwarmState:
    """Minimise ``objective`` over ``[0,1]^dim``: ``particles * (iterations + 1)`` evaluations.

    ``state`` continues a swarm (from a checkpoint) up to ``iterations``; ``callback`` sees every iteration.
    """
    if iterations < 0:
        raise InputError(f"PSO iterations must be >= 0, got {iterations}")
    if state is None:
        state = swarm_start(objective, dim, particles, rng)
        if callback is not None:
            callback(state)
    backend = _Backend.build()
    while state.iteration < iterations:
        state = swarm_step(state, objective, backend)
        if callback is not None:
            callback(state)
    return state


@dataclass(frozen=True)
class ParticleSwarm:
    """The swarm as a chain link of :func:`inverse.identify`: ``particles × (iterations + 1)`` evaluations."""

    particles: int = 20
    iterations: int = 30
    name: str = "pso"

    def run(self, problem: Problem, start: FloatArray | None, rng: np.random.Generator, *,
            state: State | None = None, callback: Callable[[Step], None] | None = None) -> Outcome:
        previous = SwarmState.from_arrays(state) if state else None
        done = previous.iteration if previous is not None else -1

        def report(s: SwarmState) -> None:
            if callback is not None:
                callback(Step(s.iteration, self.iterations, s.best_cost, s.to_arrays()))

        final = pso(problem.costs, problem.dim, rng, particles=self.particles, iterations=self.iterations,
                    state=previous, callback=report)
        evaluations = self.particles * (final.iteration - done)
        return Outcome(final.best_pos, final.best_cost, evaluations, f"{final.iteration} iterations",
                       final.to_arrays())
