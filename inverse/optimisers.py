"""Global search by particle swarm (seed 001 § 4.1, ref. [4]) then local least-squares refinement.

Both work in normalised coordinates ``u ∈ [0, 1]^p`` (:class:`Box`): linear in a parameter
whose bounds span less than two decades, logarithmic otherwise (e.g. c_F ∈ [1e5, 1e7]).

The swarm is pyswarms' global-best PSO, driven step by step through its backend (Star
topology, reflective boundaries, clamped velocities, constriction coefficients
w = 0.7298, c1 = c2 = 1.49618).  pyswarms has three side effects that
:func:`_contained` and :class:`_LegacyRNG` keep inside this module:

* importing it, and creating any topology or handler, calls ``logging.config.dictConfig``,
  which replaces the root logger's handlers with a stderr handler and a file handler writing
  ``report.log`` in the current directory.  Its ``Reporter`` reads a logging configuration
  from the file named by ``LOG_CFG`` first; pointing that at an empty *incremental*
  configuration turns the call into a no-op;
* it draws from numpy's global legacy RNG.  Every step runs with that RNG set to the
  swarm's own state (seeded from the caller's ``np.random.Generator`` and saved in
  checkpoints), and the caller's global state is put back afterwards.  This is not
  thread-safe: do not run it concurrently with other users of ``np.random.*``;
* its default boundary strategy wraps particles around (``periodic``): we ask for ``reflective``.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.optimize as so

from aromm.errors import InputError, NumericalError
from aromm.system import FloatArray

LOG_DECADES = 2.0  # bounds spanning this many decades or more are searched in log scale
W, C1, C2 = 0.7298, 1.49618, 1.49618  # Clerc-Kennedy constriction (Poli, Kennedy, Blackwell 2007)
V_MAX = 0.5  # velocity clamp, fraction of the normalised range per step
FD_STEP = 1e-5  # central-difference step in normalised coordinates


@dataclass(frozen=True)
class Box:
    """Bounds of the unknowns and the map ``u ∈ [0,1]^p`` ↔ physical values θ."""

    names: tuple[str, ...]
    lower: FloatArray
    upper: FloatArray
    log: tuple[bool, ...]

    @classmethod
    def from_bounds(cls, unknowns: Mapping[str, tuple[float, float]]) -> Box:
        if not unknowns:
            raise InputError("no unknowns: give at least one parameter with bounds, e.g. fibre.k=(0.05, 1.0)")
        lo, hi, log = [], [], []
        for name, bounds in unknowns.items():
            try:
                a, b = (float(v) for v in bounds)
            except (TypeError, ValueError):
                raise InputError(f"unknown {name!r}: bounds must be two numbers (lower, upper), "
                                 f"got {bounds!r}") from None
            if not (math.isfinite(a) and math.isfinite(b) and a < b):
                raise InputError(f"unknown {name!r}: bounds must be finite with lower < upper, got ({a:g}, {b:g})")
            lo.append(a)
            hi.append(b)
            log.append(a > 0 and math.log10(b / a) >= LOG_DECADES)
        return cls(tuple(unknowns), np.array(lo), np.array(hi), tuple(log))

    @property
    def dim(self) -> int:
        return len(self.names)

    def _ends(self) -> tuple[FloatArray, FloatArray]:
        lg = np.array(self.log)
        return (np.where(lg, np.log(np.where(lg, self.lower, 1.0)), self.lower),
                np.where(lg, np.log(np.where(lg, self.upper, 1.0)), self.upper))

    def to_physical(self, u: FloatArray) -> FloatArray:
        a, b = self._ends()
        s = a + np.asarray(u, dtype=float) * (b - a)
        return np.where(np.array(self.log), np.exp(s), s)

    def to_unit(self, theta: FloatArray) -> FloatArray:
        a, b = self._ends()
        t = np.asarray(theta, dtype=float)
        s = np.where(np.array(self.log), np.log(np.where(np.array(self.log), t, 1.0)), t)
        return (s - a) / (b - a)

    def dtheta_du(self, u: FloatArray) -> FloatArray:
        """Derivative of θ with respect to u, elementwise (the map is diagonal)."""
        a, b = self._ends()
        return np.where(np.array(self.log), self.to_physical(u) * (b - a), b - a)

    def as_dict(self) -> dict[str, tuple[float, float]]:
        return {n: (float(a), float(b)) for n, a, b in zip(self.names, self.lower, self.upper, strict=True)}


# ---------------------------------------------------------------- pyswarms, contained


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

    @classmethod
    def build(cls) -> _Backend:
        with _contained():
            from pyswarms.backend.handlers import BoundaryHandler, VelocityHandler
            from pyswarms.backend.operators import compute_pbest
            from pyswarms.backend.swarms import Swarm
            from pyswarms.backend.topology import Star

            return cls(Swarm, Star(), BoundaryHandler(strategy="reflective"),
                       VelocityHandler(strategy="unmodified"), compute_pbest)


class _LegacyRNG:
    """numpy's global legacy RNG swapped to our own state while pyswarms draws from it."""

    def __init__(self, state: dict[str, Any]) -> None:
        self.state = state

    @classmethod
    def seeded(cls, rng: np.random.Generator) -> _LegacyRNG:
        mt = np.random.RandomState(int(rng.integers(2**32)))
        return cls(mt.get_state(legacy=False))

    @contextmanager
    def active(self) -> Iterator[None]:
        # the legacy global RNG is what pyswarms draws from: swapped in and out on purpose
        saved = np.random.get_state(legacy=False)  # noqa: NPY002
        np.random.set_state(self.state)  # noqa: NPY002
        try:
            yield
        finally:
            self.state = np.random.get_state(legacy=False)  # noqa: NPY002
            np.random.set_state(saved)  # noqa: NPY002

    def to_arrays(self) -> dict[str, np.ndarray]:
        s = self.state
        return {"rng_key": np.asarray(s["state"]["key"], dtype=np.uint32),
                "rng_pos": np.asarray(s["state"]["pos"]), "rng_has_gauss": np.asarray(s["has_gauss"]),
                "rng_gauss": np.asarray(s["gauss"])}

    @classmethod
    def from_arrays(cls, a: Mapping[str, np.ndarray]) -> _LegacyRNG:
        return cls({"bit_generator": "MT19937", "state": {"key": np.asarray(a["rng_key"], dtype=np.uint32),
                                                          "pos": int(a["rng_pos"])},
                    "has_gauss": int(a["rng_has_gauss"]), "gauss": float(a["rng_gauss"])})


@dataclass(frozen=True)
class SwarmState:
    """Everything needed to continue a swarm exactly (checkpoints): positions in ``[0,1]^p``."""

    iteration: int
    position: FloatArray
    velocity: FloatArray
    pbest_pos: FloatArray
    pbest_cost: FloatArray
    rng: _LegacyRNG

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
                "pbest_pos": self.pbest_pos, "pbest_cost": self.pbest_cost, **self.rng.to_arrays()}

    @classmethod
    def from_arrays(cls, a: Mapping[str, np.ndarray]) -> SwarmState:
        return cls(int(a["iteration"]), np.array(a["position"]), np.array(a["velocity"]), np.array(a["pbest_pos"]),
                   np.array(a["pbest_cost"]), _LegacyRNG.from_arrays(a))


Objective = Callable[[FloatArray], FloatArray]  # (m, p) in [0,1]^p -> (m,) costs


def _costs(objective: Objective, u: FloatArray) -> FloatArray:
    c = np.asarray(objective(u), dtype=float).reshape(-1)
    if c.shape != (u.shape[0],) or np.any(np.isnan(c)):
        raise NumericalError(f"PSO: the objective returned {c.shape} values (NaN present: {bool(np.any(np.isnan(c)))})"
                             f" for {u.shape[0]} particles")
    return c


def swarm_start(objective: Objective, dim: int, particles: int, rng: np.random.Generator) -> SwarmState:
    """Uniform random particles in ``[0,1]^dim``, velocities ``(U - x)/2``, evaluated once (iteration 0)."""
    if particles < 2:
        raise InputError(f"PSO needs at least 2 particles, got {particles}")
    x = rng.random((particles, dim))
    v = 0.5 * (rng.random((particles, dim)) - x)
    cost = _costs(objective, x)
    return SwarmState(0, x, v, x.copy(), cost, _LegacyRNG.seeded(rng))


def swarm_step(state: SwarmState, objective: Objective, backend: _Backend | None = None) -> SwarmState:
    """One global-best PSO iteration through pyswarms' backend: move, evaluate, update bests."""
    dim = state.position.shape[1]
    bounds = (np.zeros(dim), np.ones(dim))
    ps = backend if backend is not None else _Backend.build()
    swarm = ps.swarm(state.position.copy(), state.velocity.copy(), options={"w": W, "c1": C1, "c2": C2},
                     pbest_pos=state.pbest_pos.copy(), pbest_cost=state.pbest_cost.copy(),
                     best_pos=state.best_pos.copy(), best_cost=state.best_cost)
    rng = _LegacyRNG(state.rng.state)
    with rng.active():
        swarm.velocity = ps.topology.compute_velocity(swarm, (-V_MAX, V_MAX), ps.velocity, bounds)
        swarm.position = np.clip(ps.topology.compute_position(swarm, bounds, ps.boundary), 0.0, 1.0)
    swarm.current_cost = _costs(objective, swarm.position)
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


# ---------------------------------------------------------------- local refinement


Residuals = Callable[[FloatArray], FloatArray]  # (m, p) in [0,1]^p -> (m, N) residuals


def jacobian(residuals: Residuals, u: FloatArray, step: float = FD_STEP) -> FloatArray:
    """d r / d u (N, p) by central differences in one batch, the stencil clipped to ``[0,1]``."""
    u = np.asarray(u, dtype=float)
    p = u.size
    plus = np.clip(u + step * np.eye(p), 0.0, 1.0)
    minus = np.clip(u - step * np.eye(p), 0.0, 1.0)
    r = residuals(np.vstack([plus, minus]))
    width = np.diag(plus - minus)
    return np.asarray(((r[:p] - r[p:]) / width[:, None]).T)


@dataclass(frozen=True)
class Refinement:
    """Result of the local least-squares refinement (normalised coordinates)."""

    u: FloatArray
    cost: float
    evaluations: int
    message: str


def refine(residuals: Residuals, u0: FloatArray, *, max_iterations: int = 50,
           callback: Callable[[float], None] | None = None) -> Refinement:
    """Trust-region reflective least squares (scipy) from ``u0`` inside ``[0,1]^p``.

    Tolerances: relative change of cost, of ``u`` and of the gradient below 1e-12.  ``callback``
    receives the criterion J = ½‖r‖² after each residual evaluation.
    """
    count = 0

    def fun(u: FloatArray) -> FloatArray:
        nonlocal count
        r = residuals(u[None])[0]
        count += 1
        if callback is not None:
            callback(0.5 * float(r @ r))
        return r

    def jac(u: FloatArray) -> FloatArray:
        nonlocal count
        count += 2 * u.size
        return jacobian(residuals, u)

    start = np.clip(np.asarray(u0, dtype=float), 0.0, 1.0)
    sol = so.least_squares(fun, start, jac=jac, bounds=(0.0, 1.0), method="trf", ftol=1e-12, xtol=1e-12,
                           gtol=1e-12, max_nfev=max_iterations)
    return Refinement(np.asarray(sol.x), float(sol.cost), count, str(sol.message))

