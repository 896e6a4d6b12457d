"""AROMM against pyMOR's reductors on one wood VER and scenario, every reduced model exact in time.

Scenario 1 of [Chavez2020, Table 1] (500 W/m² into z0, h = 20 W/(m² K) on z1, 60 s, outputs every 0.1 s)
on the spruce-like 24³ VER of ``aromm.studies.chavez2020.small_wood`` (default) or the shipped 46³ VER
(``--shipped``: data/scenes/wood_s1.toml) [Milk2016].  For each method and order ñ the table gives:

* offline wall / CPU seconds (stages shared by the aromm methods — Dirichlet/Steklov bases and the
  default correction vectors — are timed once per Ñ and counted in every aromm row; BT's Gramians once
  and counted in every BT row);
* online: one evaluation of the reduced model over the 600 output times at the reference parameters,
  wall ms (median of 5), exact in time (aromm's modal evaluator; for the Petrov–Galerkin ROMs of BT and
  IRKA the same formula with the complex eigendecomposition of E⁻¹A);
* the largest error (°C) of the two face means over all output times at the reference parameters
  (k_F = 0.3 W/(m K), c_F = 4e6 J/(m³ K), the scene's values) and the worst over the grid
  k_F ∈ {0.1, 0.3, 1} × c_F ∈ {1e6, 4e6, 1e7}, against the full FE model exact in time
  (benchmarks/mor_truth.py: rational Krylov Galerkin, its own error printed).

Methods: ``aromm`` (amalgam, the papers' method, with the default correction vectors), ``aromm+shifts``
(plus shifted-solve corrections at 4 shifts from 1/t_end to 1/t_first, aromm.reduction.shifted), ``pod`` (POD of the
amalgam's reference snapshots; refused beyond their rank), ``greedy`` (aromm.reduction.greedy POD-greedy on the 3×3
training grid k_F ∈ {0.05, 0.22, 1} × c_F ∈ {1e5, 1e6, 1e7}, the identification bounds), ``greedy+shifts``
(the same with shifted-solve corrections at the 4 corners of the training box), ``bt`` (pyMOR
balanced truncation [Moore1981] at the reference; parametric ROM by projecting the affine operators with its V, W),
``irka`` (pyMOR IRKA [Gugercin2008] at the reference, same projection), ``gramian-pod`` (POD in the C(μ_ref) product of
pyMOR's low-rank controllability Gramian factors at the 9 training points; Galerkin, affine), and ``detailed``
(no reduction: the whole detailed basis Φ of Ñ modes and correction vectors that the aromm reductors start
from, i.e. the floor of their error; its ñ column is the order the row belongs to, the model has Ñ + m).

    pip install -e ".[mor]"
    nice python benchmarks/mor_peers.py                     # 24³, orders 5 10 20 50 100 200
    nice python benchmarks/mor_peers.py --shipped --orders 20 50 200 --irka-orders 5 10

The machine is shared: wall and CPU seconds and the load average are printed side by side.

Measured 2026-11-30 on the default 24³ VER (15,625 DOFs; ``nice python benchmarks/mor_peers.py``, behind other
jobs on 2 cores: wall seconds and online milliseconds are inflated, trust CPU seconds).  Truth: own error
4.0e-11 °C (max face mean 27.5 °C).  Worst error °C over the 3×3 grid (at k_F = 0.1, c_F = 1e7 from ñ = 20 on
for the aromm methods), offline CPU s in brackets; bt and irka: error at the reference / worst:

    ñ    aromm        +shifts      pod      greedy       greedy+shifts  detailed Φ (Ñ)  bt                gramian-pod
    5    1.4 (4.5)    1.4 (7.9)    1.7e-1   4.7e-2 (4.5) 4.7e-2 (14)    3.1e-3 (43)     1.7e-2 / 3.1e-1   1.7 (111)
    10   1.8e-1 (4.9) 3.4e-1       1.3e-1   1.5e-3 (5.0) 2.4e-3 (13)    1.6e-3 (51)     4.5e-4 / 5.9e-2   5.1e-1
    20   3.0e-3 (5.3) 1.3e-1       2.7e-3   1.5e-3 (5.4) 3.3e-5 (14)    1.6e-3 (66)     1.1e-6 / (c)      4.9e-3
    50   1.5e-3 (8.8) 4.0e-4 (12)  1.3e-3   1.3e-3 (9.4) 5.5e-6 (16)    1.3e-3 (111)    refused (a)       1.7e-4
    100  1.2e-3 (13)  9.5e-5 (16)  refused  1.1e-3 (14)  4.4e-6 (21)    1.1e-3 (186)    refused (a)       1.0e-5
    200  9.9e-4 (19)  6.7e-5 (22)  refused  9.6e-4 (24)  3.8e-6 (31)    9.6e-4 (336)    refused (a)       refused (b)

refused: pod "POD order 100 is more than the snapshots hold: 75 available (17 kept columns + snapshot rank
58)"; (a) pyMOR "r needs to be smaller than the sizes of Gramian factors"; (b) the 9 Gramian factors span rank
133; (c) the projected model grows at a grid point away from the reference (the row says "unstable
at …").  bt 41 CPU s (Gramians, every order); irka (20 iterations, not converged): 9.2e-2 / 7.3e-1 at
r = 5, 1.9e-3 / 1.2e-1 at r = 10.  Online: 0.3–2 ms per evaluation up to ñ = 20.

``krylov`` (aromm.reduction.krylov, eigen-free, box k_F ∈ [0.1, 1] × c_F ∈ [1e6, 1e7]), measured 2026-12-01 on the
same 24³ VER
(``python benchmarks/mor_peers.py --methods krylov --orders 20 30 40 50 100 --krylov-compressions auto``, i.e.
the greedy stopped at an output change of 1e-7 °C, load average 7–11 on 2 cores, CHOLMOD solves): a span of 103
columns at 7 parameter points (252 shifted solves, 20.2 CPU s), worst error over the grid 1.1e-7 °C; compressed
(auto) to ñ = 20 / 30 / 40: 1.4e-5 / 4.1e-6 / 4.5e-7 °C (ñ = 50 keeps 40 columns, 4.5e-7), 22.9 CPU s offline in
all; peak 0.34 GB.
Without the outputs' moments (``--krylov-no-dual``, span of 83 at 10 points) the floor is 2.2e-6 °C, and the
compressions compare as (worst °C at ñ = 20 / 30 / 40 / 50): gramian 1.2e-3 / 5.3e-5 / 8.0e-6 / 2.3e-6, POD-greedy
3.5e-5 / 2.1e-5 / 6.0e-6 / 9.7e-7, POD of the moments 1.8e-4 / 1.0e-5 / 3.0e-6 / 2.0e-6, trajectory POD
5.1e-5 / 1.5e-4 / 6.2e-6 / 2.9e-6: none wins everywhere, hence ``auto`` (the smallest loss measured on the
training grid).
On the shipped 46³ VER (``--shipped --methods krylov --orders 30 40 50 100 --krylov-compressions auto gramian
greedy pod``, same day, load average 4–10; multigrid-PCG solves): a span of 88 columns at 6
points, 216 solves (CG 8–16 iterations at rtol 1e-10), 120.8 CPU s (1,092 s wall), worst over the grid 1.1e-7 °C;
auto at ñ = 30 / 40 (32 kept) / 50: 1.3e-6 / 1.2e-6 / 5.3e-7 °C; gramian 3.6e-5 / 9.0e-6 / 9.9e-7, greedy
9.0e-6 / 6.3e-6 / 7.5e-7, pod 1.3e-6 / 1.5e-6 / 5.3e-7; peak 1.00 GB.  Truth: own error 1.2e-10 °C, 511 CPU s.

Every method on the shipped 46³ VER in one run, 2026-12-02 (commit 9374f13, ``nice python benchmarks/mor_peers.py
--shipped --orders 20 50 100 --truth truth46.npz --methods aromm greedy+shifts krylov bt gramian-pod
--krylov-compressions auto --json …``, one BLAS thread, a 256³ build on the other core: load 1.3–2.1; record
``benchmarks/records/mor_peers_46_9374f13.json``).  Worst error °C over the 3×3 grid, offline CPU s in brackets:

    ñ    aromm         greedy+shifts  krylov (auto)   bt (pyMOR)                    gramian-pod (pyMOR)
    20   4.7e-3 (57)   1.8e-5 (139)   7.3e-6 (34)     7.1e-2; 3.5e-7 at ref (551)   2.7e-2 (1,429)
    50   2.3e-3 (78)   1.4e-5 (165)   4.0e-7 (34)     refused (a)                   3.3e-4 (1,430)
    100  2.4e-3 (118)  1.4e-5 (208)   1.1e-7 (span)   refused (a)                   2.3e-5 (1,430)

krylov: one span of 83 columns at 6 points (144 solves, multigrid CG 2–15 iterations), 33.2 CPU s, worst 1.1e-7 °C
(the ñ = 100 row: the whole span, 83 < 100); compressed (auto) at ñ = 20 / 50 from the same span.  irka not run
(at 24³ it did not converge in 20 iterations).  Peak 2.40 GB (pyMOR's Gramians).

The amalgam, POD and the greedy all stop at the error of the detailed basis Φ (1e-3 °C at the slow corner
of the grid); the greedy gets there at ñ = 10 instead of 50.  Shifted-solve corrections at the corners of
the training box lower that floor 250× (greedy+shifts, 3.8e-6 at ñ = 200).  The 16³ run (same day) gave the
same picture.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import resource
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import scipy.linalg as sla

from aromm.core.cache import NpzCache
from aromm.core.errors import InputError
from aromm.core.system import FloatArray, Term, ThermalSystem
from aromm.reduction.corrections import correction_samples, with_corrections
from aromm.reduction.greedy import PodGreedy
from aromm.reduction.modal_bases import compute_basis, split_modes
from aromm.reduction.offline import default_modes, reduce
from aromm.reduction.rom import ReducedModel
from aromm.reduction.shifted import default_shifts, shifted_samples
from aromm.scene.scene_file import assemble, load_scene
from aromm.studies.chavez2020 import loading, small_wood

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mor_truth import krylov_outputs

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = {"fibre.k": 0.3, "fibre.c": 4e6}
GRID = [{"fibre.k": k, "fibre.c": c} for k in (0.1, 0.3, 1.0) for c in (1e6, 4e6, 1e7)]
TRAINING = [{"fibre.k": float(k), "fibre.c": c} for k in np.geomspace(0.05, 1.0, 3) for c in (1e5, 1e6, 1e7)]
#: Reference properties of the amalgam [Chavez2020, § 3.1–3.2] (the shipped scenes' [reduction] section): bases
#: at k_F = 0.53 W/(m K), c_F = 1.2e6 J/(m³ K), reference simulation at k_F = 0.1, c_F = 1.2e6.
PAPER_BASIS = {"fibre.k": 0.53, "fibre.c": 1.2e6}
PAPER_REFERENCE = {"fibre.k": 0.1, "fibre.c": 1.2e6}
TRUTH_SHIFTS = (0.0, 1.0, 10.0, 100.0)  # 1/s
TRUTH_STEPS = 40


@dataclass
class Row:
    method: str
    order: int
    offline_wall: float  # s
    offline_cpu: float  # s
    online_ms: float  # one evaluation over all output times, wall ms
    error_reference: float  # °C
    error_worst: float  # °C, over GRID
    worst_at: str
    note: str = ""


def clock() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def since(start: tuple[float, float]) -> tuple[float, float]:
    wall, cpu = clock()
    return wall - start[0], cpu - start[1]


def median_ms(fn: Callable[[], object], repeats: int = 5) -> float:
    fn()
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(samples)


# ----------------------------------------------------------------- Petrov–Galerkin ROMs (BT, IRKA)


@dataclass(frozen=True)
class ProjectedLTI:
    """``W``ᵀ(affine system)``V``: E_r(μ) ẋ = A_r(μ) x + b_r(μ), y = C V x, x(0) = 0 (initial.T = 0)."""

    system: ThermalSystem
    capacity: tuple[FloatArray, ...]
    conductance: tuple[FloatArray, ...]
    load: tuple[FloatArray, ...]
    output: FloatArray

    @classmethod
    def project(cls, system: ThermalSystem, v: FloatArray, w: FloatArray) -> ProjectedLTI:
        _, e = system.observation_matrix()
        return cls(system, tuple(w.T @ (t.operator @ v) for t in system.capacity.terms),
                   tuple(w.T @ (t.operator @ v) for t in system.conductance.terms),
                   tuple(w.T @ np.asarray(t.operator, dtype=float) for t in system.load.terms), e @ v)

    def matrices(self, values: Mapping[str, float]) -> tuple[FloatArray, FloatArray, FloatArray]:
        """E_r, A_r, b_r at one parameter set."""
        v = self.system.values(values)

        def combine(terms: tuple[Term, ...], ops: tuple[FloatArray, ...]) -> FloatArray:
            return sum((float(t.coefficient(v)) * m for t, m in zip(terms, ops, strict=True)),
                       start=np.zeros_like(ops[0]))

        return (combine(self.system.capacity.terms, self.capacity),
                -combine(self.system.conductance.terms, self.conductance),
                combine(self.system.load.terms, self.load))

    def outputs(self, values: Mapping[str, float], times: FloatArray) -> FloatArray:
        """Exact step response: M = E⁻¹A = X Λ X⁻¹, x(t) = X φ(Λt) t X⁻¹ E⁻¹b, φ(z) = (eᶻ − 1)/z."""
        e, a, b = self.matrices(values)
        lam, x = sla.eig(np.linalg.solve(e, a))
        g = np.linalg.solve(x, np.linalg.solve(e, b))
        z = np.outer(times, lam)
        with np.errstate(over="ignore", invalid="ignore"):  # a growing mode overflows: Study.row reports it
            phi = np.where(np.abs(z) < 1e-8, 1.0 + z / 2, np.expm1(z) / np.where(np.abs(z) < 1e-8, 1.0, z))
        states = (phi * times[:, None] * g[None, :]) @ x.T
        return np.real(states @ self.output.T)

    def check(self, values: Mapping[str, float], times: FloatArray) -> float:
        """Largest difference from the augmented-matrix exponential (scipy expm) at the first and last time."""
        e, a, b = self.matrices(values)
        r = a.shape[0]
        aug = np.zeros((r + 1, r + 1))
        aug[:r, :r] = np.linalg.solve(e, a)
        aug[:r, r] = np.linalg.solve(e, b)
        ends = times[[0, -1]]
        ref = np.array([(sla.expm(aug * t)[:r, r]) @ self.output.T for t in ends])
        return float(np.abs(ref - self.outputs(values, ends)).max())


def columns(va: object, n: int) -> FloatArray:
    """A pyMOR VectorArray as an (n × len) NumPy array (pyMOR ≥ 2024 stores vectors as columns)."""
    arr = np.asarray(va.to_numpy())  # type: ignore[attr-defined]
    return arr if arr.shape[0] == n else arr.T


# ----------------------------------------------------------------- the runs


class Study:
    """One system, its exact reference outputs on GRID, and the error/timing of any reduced model."""

    def __init__(self, system: ThermalSystem, times: FloatArray, stored: Path | None = None,
                 wait: bool = False) -> None:
        self.system = system
        self.times = times
        self.stored = stored
        self.wait = wait
        self._truth: dict[int, FloatArray] = {}
        self.truth_error: dict[int, float] = {}
        self.truth_seconds = (0.0, 0.0)

    @property
    def truth(self) -> dict[int, FloatArray]:
        """Reference outputs on GRID: loaded from ``stored`` (waited for when ``wait``), else computed (and
        written there) on first use, so that a run builds its reduced models while another computes them."""
        if self._truth:
            return self._truth
        while self.wait and self.stored is not None and not self.stored.exists():
            time.sleep(10.0)
        if self.stored is not None and self.stored.exists():
            with np.load(self.stored) as data:
                self._truth = {i: data["outputs"][i] for i in range(len(GRID))}
                self.truth_error = {i: float(data["errors"][i]) for i in range(len(GRID))}
                self.truth_seconds = (float(data["seconds"][0]), float(data["seconds"][1]))
            return self._truth
        start = clock()
        for i, mu in enumerate(GRID):
            self._truth[i], self.truth_error[i] = krylov_outputs(self.system, mu, self.times, TRUTH_STEPS,
                                                                 TRUTH_SHIFTS)
        self.truth_seconds = since(start)
        if self.stored is not None:
            partial = self.stored.with_suffix(".partial.npz")
            np.savez(partial, outputs=np.stack([self._truth[i] for i in range(len(GRID))]),
                     errors=np.array([self.truth_error[i] for i in range(len(GRID))]),
                     seconds=np.array(self.truth_seconds))
            partial.replace(self.stored)
        return self._truth

    def describe(self) -> str:
        peak = max(np.abs(y).max() for y in self.truth.values())
        own_error = max(self.truth_error.values())
        return (f"truth: rational Krylov Galerkin, shifts {TRUTH_SHIFTS} 1/s × {TRUTH_STEPS} steps; own error "
                f"(change from half the steps) max {own_error:.1e} °C over the grid; {self.truth_seconds[0]:.0f} s "
                f"wall, {self.truth_seconds[1]:.0f} s CPU; max face mean {peak:.1f} °C")

    def row(self, method: str, order: int, offline: tuple[float, float],
            evaluate: Callable[[Mapping[str, float]], FloatArray], note: str = "") -> Row:
        errors = [float(np.abs(evaluate(mu) - self.truth[i]).max()) for i, mu in enumerate(GRID)]
        errors = [err if np.isfinite(err) else np.inf for err in errors]  # overflow: a growing mode

        def label(mu: Mapping[str, float]) -> str:
            return f"k={mu['fibre.k']:g},c={mu['fibre.c']:.0e}"

        unstable = [label(mu) for mu, err in zip(GRID, errors, strict=True) if err == np.inf]
        if unstable:  # Petrov–Galerkin projections (BT, IRKA) need not stay stable away from their reference
            note = "; ".join(filter(None, [note, f"unstable (growing modes) at {' '.join(unstable)}"]))
        ref = errors[GRID.index(REFERENCE)]
        worst = int(np.argmax(errors))
        online = median_ms(lambda: evaluate(REFERENCE))
        return Row(method, order, offline[0], offline[1], online, ref, errors[worst], label(GRID[worst]), note)


def aromm_rows(study: Study, orders: Sequence[int], methods: Sequence[str], cache_dir: Path) -> list[Row]:
    system = study.system
    store = NpzCache(cache_dir)
    rows = []
    samples = correction_samples(system, PAPER_BASIS)
    for order in orders:
        n_d, n_s = split_modes(system, default_modes(order))
        start = clock()
        basis = compute_basis(system, n_d, n_s, PAPER_BASIS, cache=store)
        with_corrections(system, basis, samples, values=PAPER_BASIS, cache=store)
        shared = since(start)
        for method in methods:
            options: dict[str, object] = {"basis_values": PAPER_BASIS, "reference_values": PAPER_REFERENCE}
            shifts = default_shifts(system.time, 4)
            if method == "aromm+shifts":
                options["corrections"] = samples + shifted_samples([{**system.parameters, **PAPER_BASIS}], shifts)
            elif method == "greedy+shifts":  # shifted solves at the corners of the training box
                corners = [{**system.parameters, **mu} for mu in TRAINING if mu["fibre.k"] in (TRAINING[0]["fibre.k"],
                           TRAINING[-1]["fibre.k"]) and mu["fibre.c"] in (1e5, 1e7)]
                options["corrections"] = samples + shifted_samples(corners, shifts)
                options["method"] = PodGreedy.over(TRAINING)
            elif method == "greedy":
                options["method"] = PodGreedy.over(TRAINING)
            elif method == "pod":
                options["method"] = "pod"
            start = clock()
            try:
                # "detailed": the whole basis Φ (Ñ modes + corrections), the floor every aromm reductor works above
                size = 10**9 if method == "detailed" else order
                rom = reduce(system, order=size, modes=default_modes(order), cache=store,
                             **options)  # type: ignore[arg-type]
            except InputError as err:
                rows.append(Row(method, order, np.nan, np.nan, np.nan, np.nan, np.nan, "", f"refused: {err}"))
                print(format_row(rows[-1]), flush=True)
                continue
            own = since(start)
            offline = (shared[0] + own[0], shared[1] + own[1])
            note = f"Ñ={rom.info['modes']}" + (f", ñ={rom.order}" if rom.order != order else "")
            rows.append(study.row(method, order, offline, lambda mu, rom=rom: rom.simulate(mu, study.times).as_array(),
                                  note))
            print(format_row(rows[-1]), flush=True)
    return rows


#: The identification box of issue 25 (the 3×3 grid's range) over which ``method="krylov"`` picks its points.
KRYLOV_BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}


def krylov_rows(study: Study, orders: Sequence[int], compressions: Sequence[str], *, tolerance: float,
                solver: str, max_points: int, highest: float, dual: bool) -> list[Row]:
    """aromm.reduction.krylov: one greedy rational-Krylov span over KRYLOV_BOX (timed once, counted in every row), then
    each compression to each order (its own time added); ``krylov-span`` is the whole span (the floor)."""
    from aromm.reduction.compression import compress, loss
    from aromm.reduction.krylov import KrylovReductor, build_span
    from aromm.reduction.rom import one_blas_thread
    from aromm.reduction.scipy_engine import ScipyEngine
    from aromm.reduction.training_box import material_box, training_set

    system = study.system
    assert system.time is not None
    reductor = KrylovReductor.over(KRYLOV_BOX, tolerance=tolerance, solver=solver, max_points=max_points,
                                   highest=highest, dual=dual)
    box = material_box(system, reductor.bounds)
    shifts = reductor.shift_values(system.time)
    training = training_set(box, reductor.per_axis)
    start = clock()
    engine = ScipyEngine(system, solver)
    with one_blas_thread():
        span = build_span(engine, reductor, box, study.times, shifts, max_width=10**6)
    shared = since(start)
    stats = engine.stats
    its = stats.iterations
    note = (f"{len(span.points)} points, {stats.solves} solves ({stats.method}"
            + (f", CG its {min(its)}–{max(its)}" if its else "") + f"), estimate {span.history[-1]:.1e}")
    rows = [study.row("krylov-span", span.model.order, shared,
                      lambda mu: span.model.simulate(mu, study.times).as_array(), note)]
    print(format_row(rows[-1]), flush=True)
    kept = np.eye(span.model.order)[:, :1]
    for method in compressions:
        for order in orders:
            if order >= span.model.order:
                continue
            start = clock()
            with one_blas_thread():
                a = compress(span.model, method, order, training=training, times=study.times, kept=kept,
                             moments=span.moments, tolerance=tolerance / 2)
                rom = span.model.transform(a)
            own = since(start)
            lost = loss(span.model, a, training, study.times)
            rows.append(study.row(f"krylov-{method}", order, (shared[0] + own[0], shared[1] + own[1]),
                                  lambda mu, rom=rom: rom.simulate(mu, study.times).as_array(),
                                  f"span {span.model.order}, loss {lost:.1e} on the training grid"
                                  + (f", ñ={rom.order}" if rom.order != order else "")))
            print(format_row(rows[-1]), flush=True)
    return rows


def pymor_rows(study: Study, orders: Sequence[int], irka_orders: Sequence[int], methods: Sequence[str],
               *, irka_maxit: int, solver: str) -> list[Row]:
    from pymor.core.defaults import set_defaults
    from pymor.core.logger import set_log_levels
    from pymor.reductors.bt import BTReductor
    from pymor.reductors.h2 import IRKAReductor

    from aromm.interop.pymor import mu_of, to_lti

    set_log_levels({"pymor": "WARN"})
    system = study.system
    if solver == "aromm" and system.geometry is not None:
        from mor_solver import NestedDissectionSolver

        set_defaults({"pymor.operators.numpy.NumpyMatrixOperator.default_sparse_solver":
                      functools.partial(NestedDissectionSolver, system.geometry.points)})
    fom = to_lti(system)
    mu_ref = mu_of(fom, system.values(REFERENCE))
    rows: list[Row] = []
    if "bt" in methods:
        start = clock()
        bt = BTReductor(fom, mu=mu_ref)
        bt.reduce(min(orders))
        gramians = since(start)
        for order in orders:
            start = clock()
            try:
                bt.reduce(order)
            except Exception as err:
                rows.append(Row("bt", order, np.nan, np.nan, np.nan, np.nan, np.nan, "", f"failed: {err}"))
                continue
            rom = ProjectedLTI.project(system, columns(bt.V, system.n), columns(bt.W, system.n))
            own = since(start)
            note = f"expm check {rom.check(REFERENCE, study.times):.1e}"
            rows.append(study.row("bt", order, (gramians[0] + own[0], gramians[1] + own[1]),
                                  lambda mu, rom=rom: rom.outputs(mu, study.times), note))
            print(format_row(rows[-1]), flush=True)
    if "irka" in methods:
        for order in irka_orders:
            start = clock()
            irka = IRKAReductor(fom, mu=mu_ref)
            irka.reduce(order, maxit=irka_maxit)
            rom = ProjectedLTI.project(system, columns(irka.V, system.n), columns(irka.W, system.n))
            offline = since(start)
            conv = irka.conv_crit[-1] if getattr(irka, "conv_crit", None) else np.nan
            note = f"{len(irka.conv_crit)} it, crit {conv:.1e}; expm check {rom.check(REFERENCE, study.times):.1e}"
            rows.append(study.row("irka", order, offline, lambda mu, rom=rom: rom.outputs(mu, study.times), note))
            print(format_row(rows[-1]), flush=True)
    if "gramian-pod" in methods:
        start = clock()
        factors = np.column_stack([columns(fom.gramian("c_lr", mu_of(fom, system.values(mu))), system.n)
                                   for mu in TRAINING])
        cap = system.capacity.evaluate(system.values(REFERENCE))
        gram = factors.T @ (cap @ factors)
        w, u = np.linalg.eigh((gram + gram.T) / 2)
        order_desc = np.argsort(w)[::-1]
        w, u = w[order_desc], u[:, order_desc]
        rank = int(np.count_nonzero(w > 1e-14 * w[0]))
        shared = since(start)
        for order in orders:
            if order > rank:
                rows.append(Row("gramian-pod", order, np.nan, np.nan, np.nan, np.nan, np.nan, "",
                                f"refused: Gramian factors have rank {rank}"))
                continue
            start = clock()
            v = factors @ (u[:, :order] / np.sqrt(w[:order]))
            rom = ReducedModel.from_system(system, v)
            own = since(start)
            rows.append(study.row("gramian-pod", order, (shared[0] + own[0], shared[1] + own[1]),
                                  lambda mu, rom=rom: rom.simulate(mu, study.times).as_array(),
                                  f"{factors.shape[1]} factor columns"))
            print(format_row(rows[-1]), flush=True)
    return rows


def format_row(r: Row) -> str:
    if r.note.startswith(("refused", "failed")):
        return f"{r.method:13s} {r.order:4d}  {r.note}"
    return (f"{r.method:13s} {r.order:4d} {r.offline_wall:9.1f} {r.offline_cpu:9.1f} {r.online_ms:9.2f} "
            f"{r.error_reference:11.2e} {r.error_worst:11.2e}  {r.worst_at:16s} {r.note}")


HEADER = (f"{'method':13s} {'ñ':>4s} {'off wall s':>9s} {'off CPU s':>9s} {'online ms':>9s} {'err ref °C':>11s} "
          f"{'worst °C':>11s}  {'worst at':16s} note")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shipped", action="store_true", help="the shipped 46³ VER (data/scenes/wood_s1.toml)")
    parser.add_argument("--size", type=int, default=24, help="voxels per side of the generated VER (default 24)")
    parser.add_argument("--orders", type=int, nargs="+", default=[5, 10, 20, 50, 100, 200])
    parser.add_argument("--irka-orders", type=int, nargs="+", default=[5, 10])
    parser.add_argument("--irka-maxit", type=int, default=20)
    parser.add_argument("--methods", nargs="*", default=["aromm", "aromm+shifts", "pod", "greedy", "greedy+shifts",
                                                            "detailed", "krylov", "bt", "irka", "gramian-pod"])
    parser.add_argument("--krylov-compressions", nargs="+", default=["gramian", "pod", "greedy"],
                        help="compressions of the krylov span to measure (aromm.reduction.compression)")
    parser.add_argument("--krylov-tolerance", type=float, default=1e-6, help="greedy tolerance of krylov (°C)")
    parser.add_argument("--krylov-points", type=int, default=10, help="most parameter points of krylov")
    parser.add_argument("--krylov-highest", type=float, default=3.0, help="largest krylov shift × t_first")
    parser.add_argument("--krylov-no-dual", action="store_true", help="krylov: no moments of the outputs")
    parser.add_argument("--krylov-solver", default="auto", help="shifted solves of krylov: auto, cholmod, mg")
    parser.add_argument("--pymor-solver", choices=("aromm", "default"), default="aromm",
                        help="sparse solver inside pyMOR: aromm's CHOLMOD/nested dissection (benchmarks/mor_solver.py, "
                             "BT 214 s instead of ~600 s at 24³) or pyMOR's default SuperLU/COLAMD")
    parser.add_argument("--truth", type=Path, default=None, help="reference outputs file (.npz): loaded if it "
                        "exists, else computed and written (share it between runs on the same VER)")
    parser.add_argument("--wait-truth", action="store_true", help="wait for --truth to be written by another run")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows as JSON")
    args = parser.parse_args()

    scene = load_scene(ROOT / "data" / "scenes" / "wood_s1.toml") if args.shipped else loading(
        small_wood(args.size), "z")
    system = assemble(scene)
    assert system.time is not None
    times = system.time.times
    print(f"{'shipped 46³' if args.shipped else f'generated {args.size}³'} wood VER, scenario 1: {system.n} DOFs, "
          f"{times.size} output times {times[0]:g}…{times[-1]:g} s; load average {os.getloadavg()}")
    study = Study(system, times, args.truth, args.wait_truth)
    if not args.methods:
        print(study.describe())
    print(HEADER, flush=True)
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        aromm_methods = [m for m in args.methods if m in ("aromm", "aromm+shifts", "pod", "greedy", "greedy+shifts",
                                                          "detailed")]
        if aromm_methods:
            rows += aromm_rows(study, args.orders, aromm_methods, Path(tmp))
    if "krylov" in args.methods:
        rows += krylov_rows(study, args.orders, args.krylov_compressions, tolerance=args.krylov_tolerance,
                            solver=args.krylov_solver, max_points=args.krylov_points,
                            highest=args.krylov_highest, dual=not args.krylov_no_dual)
    peers = [m for m in args.methods if m in ("bt", "irka", "gramian-pod")]
    if peers:
        rows += pymor_rows(study, args.orders, args.irka_orders, peers, irka_maxit=args.irka_maxit,
                           solver=args.pymor_solver)
    print("\n" + study.describe())
    print(HEADER)
    for r in sorted(rows, key=lambda r: (r.method, r.order)):
        print(format_row(r))
    print(f"peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB; "
          f"load average {os.getloadavg()}")
    if args.json is not None:
        args.json.write_text(json.dumps([asdict(r) for r in rows], indent=1))


if __name__ == "__main__":
    main()
