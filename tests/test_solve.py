"""Full-order solvers against independent truths: matrix exponential, conservation of energy."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as sla

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import FullModel, simulate, steady_field, transient

TWO_PHASES = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4.0e6)]
SCENARIO_1 = [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0, T_ext=0.0)]


def _two_phase_labels(shape: tuple[int, int, int], seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 2, size=shape)


def _semi_discrete_truth(system, values, t):  # type: ignore[no-untyped-def]
    """Exact solution of C T' + K T = F (no Dirichlet) by the matrix exponential: T_inf + e^{-C^-1 K t}(T0 - T_inf)."""
    v = system.values(values)
    c = system.capacity.evaluate(v).toarray()
    k = system.conductance.evaluate(v).toarray()
    f = system.load.evaluate(v)
    t_inf = np.linalg.solve(k, f)
    a = np.linalg.solve(c, k)
    t0 = np.full(system.n, float(v["initial.T"]))
    e = np.vstack(list(system.observation.values()))
    return e @ (t_inf + sla.expm(-a * t) @ (t0 - t_inf))


@pytest.mark.parametrize(("scheme", "order"), [("euler", 1.0), ("bdf2", 2.0)])
def test_time_stepping_converges_at_its_order(scheme: str, order: float) -> None:
    labels = _two_phase_labels((3, 3, 4))
    t_end = 2.0
    errors = []
    for dt in (0.2, 0.1, 0.05):
        system = assemble_voxels(labels, (1e-4,) * 3, TWO_PHASES, SCENARIO_1, time=TimeGrid(t_end, dt),
                                 outputs=["z0", "z1"], initial_T=5.0)
        obs = transient(system, times=[t_end], scheme=scheme)  # type: ignore[arg-type]
        exact = _semi_discrete_truth(system, None, t_end)
        errors.append(np.max(np.abs(obs.as_array()[0] - exact)))
    rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))
    assert np.all(rates > order - 0.25), (errors, rates)


@pytest.mark.parametrize(("k_ratio", "c_ratio"), [(12.0, 3333.0), (1e4, 1e4), (1e-4, 1e-4), (1e4, 1e-4)])
def test_energy_balance_backward_euler_is_exact(k_ratio: float, c_ratio: float) -> None:
    """Stored heat = heat in - heat out, step by step (backward Euler is conservative), at any contrast."""
    labels = _two_phase_labels((4, 4, 4), seed=1)
    dt, end = 0.05, 3.0
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.025 * k_ratio, 1.2e3 * c_ratio)]
    system = assemble_voxels(labels, (1e-4,) * 3, phases, SCENARIO_1, time=TimeGrid(end, dt),
                             outputs=["z0", "z1"])
    obs = transient(system, scheme="euler", fields=True)
    assert obs.fields is not None
    v = system.values()
    cap = system.capacity.evaluate(v)
    stored = np.ones(system.n) @ (cap @ obs.fields[-1])
    area = 16 * 1e-8
    heat_in = 500.0 * area * end
    h_mass = system.conductance["H_z1"].operator
    losses = np.array([np.ones(system.n) @ (20.0 * h_mass @ f) for f in obs.fields])  # rows at dt, 2dt, ..., end
    heat_out = dt * losses.sum()
    assert abs(stored - (heat_in - heat_out)) < 1e-9 * heat_in
    assert stored > 0 and heat_out > 0  # heat is both stored and lost: a real balance, not two zeros
    assert np.all(np.isfinite(obs.fields))


def test_pure_neumann_transient_heats_linearly_and_steady_is_refused() -> None:
    labels = _two_phase_labels((3, 3, 3), seed=2)
    system = assemble_voxels(labels, (1e-4,) * 3, TWO_PHASES, [FaceSpec("z0", flux=500.0)],
                             time=TimeGrid(20.0, 0.5), outputs=["z1"])
    v = system.values()
    total_capacity = np.ones(system.n) @ (system.capacity.evaluate(v) @ np.ones(system.n))
    rate = 500.0 * 9e-8 / total_capacity
    obs = transient(system, times=[10.0, 20.0])
    slope = (obs.mean_T["z1"][1] - obs.mean_T["z1"][0]) / 10.0
    assert slope == pytest.approx(rate, rel=1e-6)
    steady_system = assemble_voxels(labels, (1e-4,) * 3, TWO_PHASES, [FaceSpec("z0", flux=500.0)])
    with pytest.raises(NumericalError, match=r"positive definite|residual|singular"):
        steady_field(steady_system)


def test_steady_limit_of_the_transient_and_dirichlet_values() -> None:
    labels = _two_phase_labels((3, 4, 5), seed=4)
    faces = [FaceSpec("x0", T=3.0), FaceSpec("x1", h=50.0, T_ext=1.0), FaceSpec("z0", flux=100.0)]
    system = assemble_voxels(labels, (1e-4,) * 3, TWO_PHASES, faces, time=TimeGrid(4000.0, 20.0),
                             outputs=["x0", "x1"])
    late = transient(system, times=[4000.0], scheme="euler")
    steady = simulate(assemble_voxels(labels, (1e-4,) * 3, TWO_PHASES, faces, outputs=["x0", "x1"]))
    assert steady.steady
    assert steady.mean_T["x0"][0] == pytest.approx(3.0, abs=1e-12)
    np.testing.assert_allclose(late.as_array()[0], steady.as_array()[0], rtol=1e-6)


def test_full_model_batch_matches_single_runs_and_rejects_unknown_parameters() -> None:
    labels = _two_phase_labels((3, 3, 3), seed=5)
    system = assemble_voxels(labels, (1e-4,) * 3, TWO_PHASES, SCENARIO_1, time=TimeGrid(1.0, 0.1),
                             outputs=["z0", "z1"])
    model = FullModel(system)
    batch = model.simulate_batch({"fibre.k": [0.1, 0.5], "fibre.c": [1e6, 3e6]}, times=[0.5, 1.0])
    single = model.simulate({"fibre.k": 0.5, "fibre.c": 3e6}, times=[0.5, 1.0]).as_array()
    np.testing.assert_allclose(batch[1], single, rtol=1e-12)
    assert not np.allclose(batch[0], batch[1])
    with pytest.raises(InputError, match="unknown parameter"):
        model.simulate({"fibre.kk": 1.0})
    with pytest.raises(InputError, match="past the end"):
        model.simulate(times=[2.0])


@pytest.mark.parametrize("method", ["cholmod", "splu", "amg"])
def test_linear_solvers_agree(method: str) -> None:
    labels = _two_phase_labels((5, 5, 5), seed=6)
    system = assemble_voxels(labels, (1e-4,) * 3, TWO_PHASES, SCENARIO_1)
    reference = steady_field(system, method="splu")
    np.testing.assert_allclose(steady_field(system, method=method), reference, rtol=1e-7)


def test_steady_auto_takes_the_multigrid_on_voxel_grids_from_the_crossover() -> None:
    """``auto`` → ``mg`` on a voxel system of ≥ STEADY_MG_FROM free unknowns, the direct default below and off a
    voxel grid; both give the field to the solvers' tolerance (relative residual 1e-10)."""
    from aromm.full.solve import STEADY_MG_FROM, steady_method

    small = assemble_voxels(_two_phase_labels((4, 4, 4)), (1e-4,) * 3, TWO_PHASES, SCENARIO_1)
    big = assemble_voxels(_two_phase_labels((16, 16, 16), seed=2), (1e-4,) * 3, TWO_PHASES, SCENARIO_1)
    assert big.n >= STEADY_MG_FROM > small.n
    assert steady_method(small, "auto", small.n) == "auto"
    assert steady_method(big, "auto", big.n) == "mg"
    assert steady_method(big, "splu", big.n) == "splu"
    no_grid = replace(big, geometry=None)
    assert steady_method(no_grid, "auto", big.n) == "auto"
    reference = steady_field(big, method="splu")
    scale = np.ptp(reference)
    np.testing.assert_allclose(steady_field(big), reference, atol=1e-7 * scale)
