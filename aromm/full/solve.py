"""Full-order solvers for a :class:`~aromm.core.system.ThermalSystem`.

Steady:     K(p) T = F(p)                            [Chavez2020, eq. 3 with dT/dt = 0]
Transient:  C(p) dT/dt + K(p) T = F(p), T(0) = T0    [Chavez2020, eq. 3]

Time stepping is implicit and L-stable: backward Euler (order 1) or BDF2 (order 2,
started by one backward-Euler step).  The iteration matrix ``a C / dt + K`` is
factorised once per parameter set and reused at every step (aromm.linalg.direct; CHOLMOD when
available); a matrix-free voxel system with ``method="mg"`` is stepped without any matrix
(:mod:`aromm.full.voxel_transient`).  Fixed temperatures are eliminated: the unknowns are the free nodes only,
and the fixed nodes hold their value from t = 0 on.  Loads and fixed temperatures that vary in
time (a history g(t), :mod:`aromm.core.profiles`) are evaluated at the step times ``t_n`` (implicit);
a fixed temperature that varies adds its capacity coupling ``C_fd dT_d/dt``, differentiated by the
same scheme.  A steady solve uses the held final values of the histories.

Outputs are produced on the uniform grid ``dt, 2 dt, ...``; requested output times
that fall between grid points are linearly interpolated (an O(dt^2) error, the same
order as BDF2), which :func:`simulate` reports nowhere else, so choose ``dt`` dividing
the measurement times when that matters.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from tqdm import tqdm

from aromm.core import resources
from aromm.core.errors import InputError
from aromm.core.observables import Observables
from aromm.core.profiles import Profile, time_factor
from aromm.core.resources import FLOAT
from aromm.core.system import FloatArray, ParamValues, ThermalSystem, TimeGrid
from aromm.full.voxel_transient import is_matrix_free_voxel, voxel_steps
from aromm.linalg.direct import DEFAULT_RTOL, factorize

Scheme = Literal["bdf2", "euler"]

#: A steady solve of a voxel system (one right-hand side) takes the multigrid-preconditioned CG (``"mg"``) instead of
#: the direct default from this many free unknowns on, when the method is ``"auto"``.  Fluxmetric probe of the wood
#: VERs of ``aromm.studies.chavez2020.small_wood`` (one BLAS thread, best of 3, load 1–1.5), CPU s CHOLMOD / mg:
#: 12³ 0.019 / 0.022, 16³ 0.068 / 0.043, 24³ 0.25 / 0.095, 32³ 0.75 / 0.25; shipped 46³ VER 3.5 s / 0.54 s and
#: 889 / 363 MB peak; at 128³ CHOLMOD ran out of 24 GB.  A transient keeps the direct default: one factorisation
#: serves every step.
STEADY_MG_FROM = 4_000
Fields = bool | Literal["last"]


@dataclass(frozen=True)
class _Partition:
    """Free/fixed split of the unknowns for one parameter set: fixed node i holds ``scale[i] g_owner[i](t)``."""

    free: npt.NDArray[np.int64]
    fixed: npt.NDArray[np.int64]
    scale: FloatArray
    owner: npt.NDArray[np.int64]
    histories: tuple[Profile | None, ...]

    @property
    def timed(self) -> bool:
        return any(h is not None for h in self.histories)

    def fixed_at(self, t: float) -> FloatArray:
        """Values of the fixed unknowns at time t (s; ``inf``: the held final values)."""
        if not self.timed:
            return self.scale
        return self.scale * np.array([time_factor(h, t) for h in self.histories])[self.owner]

    def full(self, n: int, free_values: FloatArray, fixed_values: FloatArray) -> FloatArray:
        out = np.empty((*free_values.shape[:-1], n))
        out[..., self.free] = free_values
        out[..., self.fixed] = fixed_values
        return out


def _partition(system: ThermalSystem, values: ParamValues) -> _Partition:
    owner = system.fixed_owner()
    fixed = np.flatnonzero(owner >= 0)
    scales = np.array([float(np.asarray(values[d.param])) for d in system.dirichlet])
    return _Partition(np.flatnonzero(owner < 0), fixed, scales[owner[fixed]] if fixed.size else np.zeros(0),
                      owner[fixed], tuple(d.time for d in system.dirichlet))


def _points(system: ThermalSystem, part: _Partition) -> FloatArray | None:
    """Coordinates of the free unknowns (for the nested-dissection ordering), when the system has them."""
    points = system.unknown_points()
    return None if points is None else points[part.free]


def _split(a: sp.csr_array, part: _Partition) -> tuple[sp.csr_array, sp.csr_array]:
    rows = a[part.free]
    return sp.csr_array(rows[:, part.free]), sp.csr_array(rows[:, part.fixed])


def _load(system: ThermalSystem, values: ParamValues, at: float = np.inf) -> FloatArray:
    if not system.load:
        return np.zeros(system.n)
    return np.asarray(system.load.evaluate(values, at), dtype=float)


class _Forcing:
    """``F_f(t) − K_fd T_d(t)`` on the free unknowns: the constant part summed once, the histories apart."""

    def __init__(self, system: ThermalSystem, values: ParamValues, part: _Partition, k_fd: sp.csr_array) -> None:
        self.part, self.k_fd = part, k_fd
        terms = system.load.terms
        self.constant = np.zeros(part.free.size)
        self.timed: list[tuple[FloatArray, Profile]] = []
        for t in terms:
            vec = float(t.coefficient(values)) * np.asarray(t.operator, dtype=float)[part.free]
            if t.time is None:
                self.constant += vec
            else:
                self.timed.append((vec, t.time))
        if not part.timed:
            self.constant -= k_fd @ part.scale

    def __call__(self, t: float) -> FloatArray:
        out = self.constant + sum((g(t) * vec for vec, g in self.timed), np.zeros_like(self.constant))
        return out - self.k_fd @ self.part.fixed_at(t) if self.part.timed else out


def _initial(system: ThermalSystem, values: ParamValues, part: _Partition) -> FloatArray:
    """Initial free values: ``initial.T`` plus the system's initial-field terms (a lifted system's)."""
    x = np.full(part.free.size, float(np.asarray(values["initial.T"])))
    return x + np.asarray(system.initial.evaluate(values), dtype=float)[part.free] if system.initial else x


def _outputs_at(system: ThermalSystem, values: ParamValues, t: float) -> FloatArray:
    """The feedthrough of the outputs at time t (zero for an assembled system)."""
    if not system.feedthrough:
        return np.zeros(len(system.observation))
    return np.asarray(system.feedthrough.evaluate(values, t), dtype=float)


def steady_field(system: ThermalSystem, values: ParamValues | None = None, method: str = "auto",
                 rtol: float = DEFAULT_RTOL) -> FloatArray:
    """Steady temperature field (K): solve ``K T = F`` with fixed temperatures eliminated (histories held at
    their final values); an iterative ``method`` to the relative residual ``rtol`` (checked)."""
    return _steady(system, system.values(values), method, rtol)[0]


def _steady(system: ThermalSystem, v: ParamValues, method: str, rtol: float) -> tuple[FloatArray, _Partition, Any]:
    """The steady field at the values ``v``, the free/fixed split and the factorised ``K_ff`` (for more solves)."""
    part = _partition(system, v)
    k_ff, k_fd = _split(sp.csr_array(system.conductance.evaluate(v)), part)
    fixed = part.fixed_at(np.inf)
    rhs = _load(system, v)[part.free] - k_fd @ fixed
    solver = factorize(k_ff, steady_method(system, method, rhs.size), rtol, points=_points(system, part))
    return part.full(system.n, solver.solve(rhs), fixed), part, solver


def steady_sensitivity(system: ThermalSystem, values: ParamValues, rows: FloatArray, scaled: Mapping[str, float], *,
                       method: str = "auto", rtol: float = DEFAULT_RTOL,
                       step: float = 1e-4) -> tuple[FloatArray, FloatArray]:
    """``y = rows T`` at steady state ((m, n) rows) and ``dy/d ln λ`` when the parameters ``scaled`` (name → value)
    are multiplied by λ at λ = 1, by the adjoint: ``dy_i = −ψ_iᵀ (dK T)_f``, ``ψ_i = K_ff⁻¹ (row_i)_f`` (K
    symmetric; one factorisation, m + 1 solves), for parameters that enter the conductance only (a phase
    conductivity: the loads and the fixed temperatures do not depend on it).  ``dK = (K(λ⁺) − K(λ⁻)) / (2 step)``:
    exact for the terms linear in the parameters, second order in ``step`` for the harmonic interface links of
    finite volumes."""
    field, part, solver = _steady(system, system.values(values), method, rtol)
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    up, down = ({**(values or {}), **{n: x * (1 + sign * step) for n, x in scaled.items()}} for sign in (1, -1))
    d_k = (sp.csr_array(system.conductance.evaluate(system.values(up)))
           - sp.csr_array(system.conductance.evaluate(system.values(down)))) / (2 * step)
    moved = (d_k @ field)[part.free]
    slopes = [-float(solver.solve(np.ascontiguousarray(row[part.free])) @ moved) for row in rows]
    return rows @ field, np.array(slopes)


def steady_method(system: ThermalSystem, method: str, unknowns: int) -> str:
    """``method``, or for ``"auto"`` on a voxel system of at least :data:`STEADY_MG_FROM` free unknowns ``"mg"``."""
    g = system.geometry
    voxels = g is not None and g.cell_type == "hexahedron" and g.nodes == system.n
    return "mg" if method == "auto" and voxels and unknowns >= STEADY_MG_FROM else method


def reaction_heat_flow(system: ThermalSystem, field: FloatArray, dofs: npt.ArrayLike,
                       values: ParamValues | None = None) -> float:
    """Heat flow (W) that fixed temperatures on the unknowns ``dofs`` inject at steady state.

    The reaction of the constraint, ``Q = Σ_{i ∈ dofs} (K T − F)_i``: the discrete flux through a face held
    at a fixed temperature (positive when heat enters the body there).
    """
    v = system.values(values)
    residual = sp.csr_array(system.conductance.evaluate(v)) @ field - _load(system, v)
    return float(np.sum(residual[np.asarray(dofs, dtype=np.int64)]))


def transient_grid(grid: TimeGrid | None, steady: bool, scheme: str) -> TimeGrid:
    """The time grid of a transient system, refusing a steady one and an unknown ``scheme``."""
    if grid is None or steady:
        raise InputError("this system is steady (no [time] section / no capacity): use a steady solve")
    if scheme not in ("bdf2", "euler"):
        raise InputError(f"unknown time scheme {scheme!r}; allowed: bdf2, euler")
    return grid


def output_steps(times: npt.ArrayLike | None, grid: TimeGrid) -> tuple[FloatArray, int]:
    """Checked output times (default: the grid's) and the number of time steps that reach them."""
    t_out = _check_times(times, grid)
    steps = round(min(grid.end, t_out[-1] + grid.dt) / grid.dt - 1e-9) + 1
    return t_out, max(1, min(steps, len(grid.times)))


def _check_times(times: npt.ArrayLike | None, grid: TimeGrid) -> FloatArray:
    if times is None:
        return grid.times
    t = np.asarray(times, dtype=float).ravel()
    if t.size == 0 or not np.all(np.isfinite(t)) or np.any(t < 0) or np.any(np.diff(t) <= 0):
        raise InputError("output times must be finite, non-negative and strictly increasing")
    if t[-1] > grid.end + 1e-9 * grid.end:
        raise InputError(f"output time {t[-1]:g} s is past the end of the simulation ({grid.end:g} s)")
    return t


def transient(
    system: ThermalSystem,
    values: ParamValues | None = None,
    times: npt.ArrayLike | None = None,
    *,
    scheme: Scheme = "bdf2",
    fields: Fields = False,
    method: str = "auto",
    progress: bool = False,
) -> Observables:
    """Implicit time integration from the uniform initial temperature ``initial.T``.

    Returns face means at ``times`` (default: the scene's grid); full fields too with ``fields``:
    ``True`` at every output time, ``"last"`` only at the last one (one row, what an export of
    the final field needs).  Fields are interpolated as the steps pass, so only the rows asked
    for are kept.  Refused before any factorisation when the kept arrays exceed the available
    memory (:mod:`aromm.core.resources`).
    """
    grid = transient_grid(system.time, system.is_steady, scheme)
    t_out, steps = output_steps(times, grid)
    v = system.values(values)
    if method == "mg" and not fields and not system.dirichlet and is_matrix_free_voxel(system):  # no matrix at all
        names, e = system.observation_matrix()
        step_t, step_y = voxel_steps(system, v, steps, grid.dt, scheme=scheme,
                                     output=lambda x, t: e @ x + _outputs_at(system, v, t))
        rows = interpolate_rows(t_out, np.asarray(step_t), np.asarray(step_y))
        return Observables(t=t_out, mean_T={name: rows[:, i] for i, name in enumerate(names)})
    part = _partition(system, v)
    c_ff, c_fd = _split(sp.csr_array(system.capacity.evaluate(v)), part)
    k_ff, k_fd = _split(sp.csr_array(system.conductance.evaluate(v)), part)
    forcing = _Forcing(system, v, part, k_fd)
    dt = grid.dt

    names, e = system.observation_matrix()
    field_t = t_out if fields is True else t_out[-1:] if fields == "last" else t_out[:0]
    resources.require(FLOAT * ((steps + 1) * len(names) * 2 + field_t.size * system.n),
                      f"the transient of {system.n} unknowns over {steps} steps",
                      f"{steps + 1} times × {len(names)} outputs × 2 copies + {field_t.size} fields × "
                      f"{system.n} unknowns, 8 bytes each",
                      "keep fewer fields (simulate --out exports only the final one), raise [time] dt or lower end")
    e_free, e_fixed = e[:, part.free], e[:, part.fixed]

    def output(x: FloatArray, t: float) -> FloatArray:
        return e_free @ x + e_fixed @ part.fixed_at(t) + _outputs_at(system, v, t)

    x_prev = _initial(system, v, part)
    history_t = [0.0]
    history_y = [output(x_prev, 0.0)]
    d_prev = d_older = part.fixed_at(0.0)
    kept = _FieldRows(field_t, part, system.n)
    kept.capture(0.0, 0.0, (x_prev, d_prev), (x_prev, d_prev))

    # Step 1 is backward Euler (BDF2's starter); the Euler factor is released before BDF2's is built,
    # so at most one factorisation is alive at a time (each costs ~1 GB at 1e5 unknowns).
    points = _points(system, part)
    stepper = factorize(c_ff / dt + k_ff, method, points=points)
    x_older = x_prev
    for n in tqdm(range(1, steps + 1), desc="time steps", disable=not progress, leave=False):
        t_n = n * dt
        euler = n == 1 or scheme == "euler"
        lead, past, past_d = (1.0, x_prev, d_prev) if euler else (
            1.5, 2.0 * x_prev - 0.5 * x_older, 2.0 * d_prev - 0.5 * d_older)
        rhs = c_ff @ past / dt + forcing(t_n)
        d_n = part.fixed_at(t_n)
        if part.timed:  # the capacity coupling to fixed temperatures that move
            rhs -= c_fd @ (lead * d_n - past_d) / dt
        x = stepper.solve(rhs)
        if n == 1 and scheme == "bdf2" and steps > 1:
            del stepper
            stepper = factorize(1.5 * c_ff / dt + k_ff, method, points=points)
        kept.capture((n - 1) * dt, t_n, (x_prev, d_prev), (x, d_n))
        x_older, x_prev = x_prev, x
        d_older, d_prev = d_prev, d_n
        history_t.append(t_n)
        history_y.append(output(x, t_n))
    kept.finish((steps - 1) * dt, steps * dt, (x_older, d_older), (x_prev, d_prev))
    ht = np.asarray(history_t)
    hy = interpolate_rows(t_out, ht, np.asarray(history_y))
    mean_t = {name: hy[:, i] for i, name in enumerate(names)}
    return Observables(t=t_out, mean_T=mean_t, fields=kept.rows if fields else None)


State = tuple[FloatArray, FloatArray]  # (free unknowns, fixed values) at one time


class _FieldRows:
    """Full fields at the times ``at`` (ascending), interpolated linearly between steps as they pass.

    Same interpolation as :func:`interpolate_rows` on the stored steps, without storing them: only
    ``len(at)`` rows of ``n`` values are kept.
    """

    def __init__(self, at: FloatArray, part: _Partition, n: int) -> None:
        self.at = at
        self.part = part
        self.rows = np.empty((at.size, n))
        self.next = 0

    def _put(self, t0: float, t1: float, s0: State, s1: State, last: bool) -> None:
        while self.next < self.at.size and (last or self.at[self.next] <= t1):
            w = (self.at[self.next] - t0) / (t1 - t0) if t1 > t0 else 1.0
            free = (1.0 - w) * s0[0] + w * s1[0]
            fixed = (1.0 - w) * s0[1] + w * s1[1]
            self.rows[self.next] = self.part.full(self.rows.shape[1], free, fixed)
            self.next += 1

    def capture(self, t0: float, t1: float, s0: State, s1: State) -> None:
        """Rows due at or before ``t1`` from the step ``t0 → t1`` (states ``s0 → s1``)."""
        self._put(t0, t1, s0, s1, last=False)

    def finish(self, t0: float, t1: float, s0: State, s1: State) -> None:
        """Rows after the last step (within round-off of it) from the last step, as interpolate_rows does."""
        self._put(t0, t1, s0, s1, last=True)


def interpolate_rows(t_out: FloatArray, t: FloatArray, rows: FloatArray) -> FloatArray:
    """Piecewise-linear interpolation of ``rows[i]`` (given at ``t[i]``) at the times ``t_out``."""
    idx = np.clip(np.searchsorted(t, t_out, side="right") - 1, 0, len(t) - 2)
    w = ((t_out - t[idx]) / (t[idx + 1] - t[idx]))[:, None]
    return (1.0 - w) * rows[idx] + w * rows[idx + 1]


def simulate(
    system: ThermalSystem,
    values: ParamValues | None = None,
    times: npt.ArrayLike | None = None,
    *,
    fields: Fields = False,
    method: str = "auto",
    scheme: Scheme = "bdf2",
    progress: bool = False,
) -> Observables:
    """Full model: steady solve for a steady system, else :func:`transient` (``fields`` as there).

    On one process; :func:`aromm.api.simulate` chooses between this and the petsc engine."""
    if system.is_steady or system.time is None:
        field = steady_field(system, values, method)
        names, e = system.observation_matrix()
        direct = _outputs_at(system, system.values(values), np.inf)
        y = e @ field
        means = {name: np.atleast_1d(y[i] + direct[i]) for i, name in enumerate(names)}
        return Observables(t=np.zeros(1), mean_T=means, steady=True, fields=field[None, :] if fields else None)
    return transient(system, values, times, scheme=scheme, fields=fields, method=method, progress=progress)


@dataclass(frozen=True)
class FullModel:
    """The full finite-element (or DEM) model behind the forward-model protocol (aromm.core.forward_model)."""

    system: ThermalSystem
    method: str = "auto"
    scheme: Scheme = "bdf2"

    @property
    def outputs(self) -> tuple[str, ...]:
        return tuple(self.system.observation)

    @property
    def parameter_names(self) -> frozenset[str]:
        return self.system.parameter_names

    @property
    def default_times(self) -> FloatArray:
        return self.system.time.times if self.system.time is not None else np.zeros(1)

    def simulate(self, params: Mapping[str, float] | None = None,
                 times: npt.ArrayLike | None = None) -> Observables:
        return simulate(self.system, params, times, method=self.method, scheme=self.scheme)

    def simulate_batch(self, params: Mapping[str, npt.ArrayLike],
                       times: npt.ArrayLike | None = None) -> FloatArray:
        arrays = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in params.items()}
        sizes = {a.size for a in arrays.values()}
        if len(sizes) > 1:
            raise InputError(f"parameter arrays must have equal lengths, got {sorted(sizes)}")
        m = sizes.pop() if sizes else 1
        out = [self.simulate({k: float(a[i]) for k, a in arrays.items()}, times).as_array() for i in range(m)]
        return np.stack(out)
