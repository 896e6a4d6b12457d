"""Finite-volume links between two phases of the coupled heat–moisture model (aromm.core.flux_cone,
aromm.physics.hygrothermal) against independent truths: the dense matrix harmonic mean, the exact steady field of a
layered bar (two-point fluxes with series conductances are exact across a layered 1-D medium), the dry limit (the
thermal finite volumes), and the reduced model's certified bound against the exact full model."""

from __future__ import annotations

import numpy as np
import pytest

from aromm.core.flux_cone import cone_harmonic
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.full.exact import exact_outputs
from aromm.full.solve import steady_field
from aromm.fv.volumes import assemble_volumes
from aromm.physics.hygrothermal import MoistureState, coupled
from aromm.reduction.lifting import lift
from aromm.reduction.rom import from_arrays, to_arrays

STATE = MoistureState(T_ref=20.0, phi_ref=0.5)
#: a wood-fibre board and still air about 20 °C, 50 % RH: k (W/(m K)), ρ c_p (J/(m³ K)), ξ (kg/m³), D_φ (kg/(m s)),
#: δ_p (kg/(m s Pa)); air carries vapour only (D_φ = 0, δ_p of still air ≈ 2e-10 [Kuenzel1995])
FIBRE = {"k": 0.3, "c": 1.4e6, "xi": 40.0, "D_phi": 2.0e-9, "delta_p": 1.0e-11}
AIR = {"k": 0.026, "c": 1.2e3, "xi": 0.01, "D_phi": 0.0, "delta_p": 2.0e-10}
PHASES = [PhaseSpec("fibre", 0, FIBRE["k"], FIBRE["c"]), PhaseSpec("air", 1, AIR["k"], AIR["c"])]
MOISTURE = {"fibre": {k: FIBRE[k] for k in ("xi", "D_phi", "delta_p")},
            "air": {k: AIR[k] for k in ("xi", "D_phi", "delta_p")}}


def _flux_matrix(props: dict[str, float]) -> np.ndarray:
    """The symmetrised 2 × 2 flux matrix of one phase (aromm.physics.hygrothermal's docstring), written out."""
    lam, a, p, lv = STATE.weight, STATE.a, STATE.p, STATE.latent_heat
    k, d, dp = props["k"], props["D_phi"], props["delta_p"]
    return np.array([[k + lv * dp * a, lv * dp * p], [lv * dp * p, lam * (d + dp * p)]])


def _cone(m: np.ndarray) -> tuple[float, float, float]:
    return m[0, 0] - m[0, 1], m[1, 1] - m[0, 1], m[0, 1]


def test_the_cone_harmonic_mean_is_the_dense_one_and_stays_in_the_cone() -> None:
    """Random cone points over six decades each: the coordinates of 2 (P⁻¹ + Q⁻¹)⁻¹ by the dense inverse (to the
    inverse's rounding, a few ε times the condition number), all ≥ 0; and a heat-only phase (y = z = 0, singular)
    as the limit of P + ε I."""
    rng = np.random.default_rng(7)
    pts = 10.0 ** rng.uniform(-3.0, 3.0, size=(200, 2, 3))
    for (x1, y1, z1), (x2, y2, z2) in pts:
        p, q = (np.diag([x, y]) + z * np.ones((2, 2)) for x, y, z in ((x1, y1, z1), (x2, y2, z2)))
        dense = 2.0 * np.linalg.inv(np.linalg.inv(p) + np.linalg.inv(q))
        got = cone_harmonic((np.array(x1), np.array(y1), np.array(z1)), (np.array(x2), np.array(y2), np.array(z2)))
        tol = 1e-13 * (np.linalg.cond(p) + np.linalg.cond(q)) * np.abs(dense).max()
        assert np.all(np.array(got) >= 0.0)
        np.testing.assert_allclose(got, _cone(dense), rtol=0, atol=tol)
    zero = np.array(0.0)
    for other in ((np.array(2.0), np.array(0.5), np.array(0.3)), (np.array(5.0), zero, zero)):
        got = cone_harmonic((np.array(1.5), zero, zero), other)
        eps = 1e-9
        p = np.diag([1.5 + eps, eps])
        q = np.diag([float(other[0]) + eps, float(other[1]) + eps]) + float(other[2]) * np.ones((2, 2))
        limit = _cone(2.0 * np.linalg.inv(np.linalg.inv(p) + np.linalg.inv(q)))
        np.testing.assert_allclose(got, limit, rtol=0, atol=1e-7)


def test_a_layered_bar_has_the_exact_steady_field_of_its_layers_in_series() -> None:
    """Fibre and air layers across x, (T, φ) fixed on both faces: the exact field is linear in each layer with one
    flux vector q through all, q = (Σ_l t_l A_l⁻¹)⁻¹ Δu; two-point fluxes with the matrix harmonic mean on the links
    between layers reproduce it to the direct solve's rounding (cell centres, both fields)."""
    layers = [0, 0, 1, 1, 1, 0, 1, 0]
    size = 1e-3
    labels = np.array(layers).reshape(-1, 1, 1)
    thermal = assemble_volumes(labels, (size,) * 3, PHASES, [FaceSpec("x0", T=25.0), FaceSpec("x1", T=15.0)],
                               outputs=["x1"])
    system = coupled(thermal, STATE, MOISTURE, fixed_phi={"x0": 0.8, "x1": 0.3})
    field = steady_field(system)
    flux = [_flux_matrix(FIBRE if label == 0 else AIR) for label in layers]
    resistance = sum(size * np.linalg.inv(a) for a in flux)
    q = np.linalg.solve(resistance, np.array([25.0 - 15.0, 0.8 - 0.3]))  # flux vector along +x
    u, exact = np.array([25.0, 0.8]), []
    for a in flux:
        centre = u - 0.5 * size * np.linalg.solve(a, q)
        exact.append(centre)
        u = u - size * np.linalg.solve(a, q)
    assert np.allclose(u, [15.0, 0.3], rtol=0, atol=1e-12)
    cells = len(layers)
    got = np.stack([field[:cells], field[system.n // 2: system.n // 2 + cells]], axis=1)
    error = np.abs(got - np.array(exact)) / np.array([10.0, 0.5])  # relative to the jumps across the bar
    assert error.max() <= 1e-9, error


def test_without_moisture_transport_the_heat_block_is_the_thermal_finite_volumes() -> None:
    """δ_p = 0 in both phases (D_φ > 0 in one): the links' heat coordinate is the thermal harmonic mean, so the T
    block of the coupled conductance is the thermal operator to rounding, and the off-diagonal blocks vanish."""
    labels = np.random.default_rng(3).integers(0, 2, size=(5, 4, 3))
    thermal = assemble_volumes(labels, (1e-3,) * 3, PHASES, [FaceSpec("x0", T=1.0)], outputs=["x1"])
    dry = {name: {**props, "delta_p": 0.0} for name, props in MOISTURE.items()}
    system = coupled(thermal, STATE, dry)
    k = system.conductance.evaluate(system.values()).toarray()
    n = thermal.n
    k_thermal = thermal.conductance.evaluate(thermal.values()).toarray()
    scale = np.abs(k_thermal).max()
    np.testing.assert_allclose(k[:n, :n], k_thermal, rtol=0, atol=1e-13 * scale)
    assert np.abs(k[:n, n:]).max() == 0.0


def test_the_reduced_model_of_a_two_phase_finite_volume_image_is_certified() -> None:
    """A Krylov model of a fibre–air image in finite volumes (humidity step on x0, sensor on x1), over fibre.delta_p
    (which every link's coefficients depend on, nonlinearly): at two inner points its certified bound holds against
    the exact full model (the rounding of the two exact evaluations allowed for)."""
    from aromm.api import reduce

    labels = np.random.default_rng(5).integers(0, 2, size=(6, 3, 3))
    thermal = assemble_volumes(labels, (1e-3,) * 3, PHASES, [FaceSpec("x0", T=20.0)], outputs=["x1"],
                               time=TimeGrid(3600.0, 300.0), initial_T=20.0)
    system = coupled(thermal, STATE, MOISTURE, fixed_phi={"x0": 0.8}, initial_phi=0.5)
    rom = reduce(system, 40, method="krylov", bounds={"fibre.delta_p": (5e-12, 2e-11)}, cache=False)
    assert system.time is not None
    times = system.time.times
    for mu in ({"fibre.delta_p": 1.5e-11}, {"fibre.delta_p": 7e-12}):
        truth = exact_outputs(lift(system), mu, times)
        actual = np.abs(rom.simulate(mu, times).as_array() - truth).max(axis=0)
        bound = rom.error_bound(mu)
        assert bound is not None and np.all(np.isfinite(bound))
        assert np.all(bound >= actual - 1e-11 * np.abs(truth).max()), (bound, actual)
    again = from_arrays(to_arrays(rom))  # the cache's round trip keeps the link coefficients (kind, weights, part)
    link = next(t for t in again.projected.conductance.terms if t.coefficient.kind == "link")
    assert link.coefficient == next(t for t in rom.projected.conductance.terms if t.name == link.name).coefficient
    mu = {"fibre.delta_p": 1.5e-11}
    np.testing.assert_array_equal(again.simulate(mu, times).as_array(), rom.simulate(mu, times).as_array())


def test_a_heat_only_phase_links_by_the_rank_one_parallel_sum() -> None:
    """A vapour-tight phase (D_φ = δ_p = 0) beside a wet one: the link keeps only its heat coordinate,
    2 / (1/x + (Q⁻¹)₁₁) in cone coordinates (the parallel sum of a rank-one matrix), which is what conduction across
    it sees; moisture does not cross."""
    tight = {"xi": 0.0, "D_phi": 0.0, "delta_p": 0.0}
    labels = np.array([0, 1]).reshape(2, 1, 1)
    thermal = assemble_volumes(labels, (1e-3,) * 3, PHASES, [FaceSpec("x0", T=1.0)], outputs=["x1"])
    system = coupled(thermal, STATE, {"fibre": MOISTURE["fibre"], "air": tight})
    k = system.conductance.evaluate(system.values()).toarray()
    a_fibre = _flux_matrix(FIBRE)
    # the link's conductance between the two cells (A/d = 1e-3 m): 2 (x⁻¹ + (A_fibre⁻¹)_TT)⁻¹ with x = AIR k
    g = 1e-3 * 2.0 / (1.0 / AIR["k"] + np.linalg.inv(a_fibre)[0, 0])
    assert k[0, 1] == pytest.approx(-g, rel=1e-12)
    n = system.n // 2
    assert k[n, n + 1] == 0.0 and k[0, n + 1] == 0.0
