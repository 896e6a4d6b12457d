"""The reduced model (aromm.reduction.offline, aromm.reduction.rom, aromm.reduction.amalgam, aromm.reduction.pod)
against exact solutions and conservation.

The reference ("truth") is the exact solution of the full semi-discrete system ``C dT/dt + K T = F`` computed
here independently with a dense generalised eigendecomposition of the full matrices (small images).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from hypothesis import given, settings
from hypothesis import strategies as st
from scene_text import scenario_1

from aromm.core.errors import InputError
from aromm.core.forward_model import ForwardModel
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import steady_field
from aromm.reduction.amalgam import amalgam
from aromm.reduction.offline import reduce
from aromm.reduction.rom import ReducedModel

H = 5e-6  # voxel size, m
PHASES = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
SCENARIO_1 = [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)]


def system_of(labels: np.ndarray, boundary=SCENARIO_1, phases=PHASES, end: float = 2.0) -> ThermalSystem:
    return assemble_voxels(labels, (H,) * 3, phases, boundary, time=TimeGrid(end, end / 20), outputs=["z0", "z1"])


def random_labels(n: int, seed: int = 0, fraction: float = 0.4) -> np.ndarray:
    return (np.random.default_rng(seed).random((n, n, n)) < fraction).astype(int)


def exact_outputs(system: ThermalSystem, values: dict[str, float], times: np.ndarray) -> np.ndarray:
    """Exact face means of the full semi-discrete system (dense eigendecomposition), (len(times), n_out)."""
    v = system.values(values)
    c = system.capacity.evaluate(v).toarray()
    k = system.conductance.evaluate(v).toarray()
    f = np.asarray(system.load.evaluate(v)) if system.load else np.zeros(system.n)
    lam, w = sla.eigh(k, c)
    y0 = w.T @ c @ np.full(system.n, float(v["initial.T"]))
    b = w.T @ f
    lam = np.where(lam < 1e-12 * lam.max(), 0.0, lam)
    ys = []
    for t in times:
        decay = np.exp(-lam * t)
        phi = np.where(lam > 0, -np.expm1(-lam * t) / np.where(lam > 0, lam, 1.0), t)
        ys.append(w @ (decay * y0 + phi * b))
    _, e = system.observation_matrix()
    return np.array(ys) @ e.T


FAR = {"fibre.k": 0.3, "fibre.c": 4e6}  # not the reference values of the bases (0.53) or the amalgam (0.1)


def test_all_modes_equals_full_model(tmp_path) -> None:
    system = system_of(random_labels(4))
    rom = reduce(system, order=system.n, modes=system.n, cache=tmp_path)
    assert rom.order == system.n
    t = np.array([1e-3, 0.05, 0.3, 2.0])
    exact = exact_outputs(system, FAR, t)
    np.testing.assert_allclose(rom.simulate(FAR, t).as_array(), exact, rtol=1e-8, atol=1e-9 * np.abs(exact).max())


def test_error_decreases_with_order(tmp_path) -> None:
    system = system_of(random_labels(5, seed=2))
    t = system.time.times
    exact = exact_outputs(system, FAR, t)
    errors = [np.abs(reduce(system, order=r, modes=system.n, cache=tmp_path).simulate(FAR, t).as_array()
                     - exact).max() for r in (3, 12, 48, system.n)]
    assert errors[0] > errors[1] > errors[2] > errors[3]
    assert errors[3] < 1e-8 * np.abs(exact).max()


def test_batch_equals_single_and_protocol(tmp_path) -> None:
    system = system_of(random_labels(5, seed=1))
    rom = reduce(system, order=20, modes=80, cache=tmp_path)
    assert isinstance(rom, ForwardModel)
    assert rom.outputs == ("z0", "z1")
    k = np.array([0.05, 0.3, 1.0])
    c = np.array([1e5, 4e6, 1e7])
    t = np.array([0.0, 0.01, 0.5, 1.7])
    batch = rom.simulate_batch({"fibre.k": k, "fibre.c": c}, t)
    assert batch.shape == (3, 4, 2)
    for i in range(3):
        single = rom.simulate({"fibre.k": float(k[i]), "fibre.c": float(c[i])}, t).as_array()
        np.testing.assert_allclose(batch[i], single, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(batch[:, 0, :], 0.0, atol=1e-10)  # initial temperature 0
    with pytest.raises(InputError, match="unknown parameter"):
        rom.simulate({"fibre.kk": 1.0})
    with pytest.raises(InputError, match="equal lengths"):
        rom.simulate_batch({"fibre.k": [1.0, 2.0], "fibre.c": [1e6]})


def test_second_reduce_is_loaded_from_cache(tmp_path) -> None:
    system = system_of(random_labels(5, seed=4))
    first = reduce(system, order=10, modes=40, cache=tmp_path)
    second = reduce(system, order=10, modes=40, cache=tmp_path)
    assert first.info["cached"] == 0 and second.info["cached"] == 1
    assert second.info["offline_seconds"] == 0.0
    t = np.array([0.1, 1.0])
    np.testing.assert_array_equal(first.simulate(FAR, t).as_array(), second.simulate(FAR, t).as_array())
    for path in tmp_path.glob("rom-*.npz"):
        with np.load(path, allow_pickle=False) as data:
            assert "outputs.matrix" in data.files


def energy(rom: ReducedModel, values: dict[str, float], t: np.ndarray) -> np.ndarray:
    """Stored heat 1ᵀ C T̃ (J) of the reduced solution: Σ_j c_j (Ψᵀ C_j 1)ᵀ X."""
    x = rom.states(values, t)
    v, _ = rom.projected.batch_values({**{k: [val] for k, val in values.items()}, "initial.T": [1.0]})
    weights = sum(float(term.coefficient(v)[0]) * term.operator for term in rom.initial.terms)
    return x @ weights


def test_pure_neumann_mean_temperature_grows_linearly(tmp_path) -> None:
    # Adiabatic body heated by q on z0: the stored heat is q A t exactly, and the face means grow at the
    # rate q A / (Σ c V) once the transient has died (zero mode kept, forced principal).
    n, q = 5, 500.0
    labels = random_labels(n, seed=5)
    system = system_of(labels, [FaceSpec("z0", flux=q)], end=4.0)
    rom = reduce(system, order=8, modes=60, cache=tmp_path)
    area = (n * H) ** 2
    heat = (labels.sum() * 4e6 + (labels.size - labels.sum()) * 1.2e3) * H**3
    t = np.linspace(0.0, 4.0, 9)
    np.testing.assert_allclose(energy(rom, {}, t), q * area * t, rtol=1e-9, atol=1e-18)
    late = rom.simulate({}, np.array([3.0, 4.0])).as_array()
    np.testing.assert_allclose(late[1] - late[0], q * area / heat, rtol=1e-3)
    with pytest.raises(Exception, match="no steady limit"):
        rom.steady()


def test_single_phase_linear_growth_rate(tmp_path) -> None:
    labels = np.ones((4, 4, 4), dtype=int)
    system = system_of(labels, [FaceSpec("z0", flux=200.0)], phases=[PhaseSpec("fibre", 1, 0.3, 4e6)], end=2.0)
    rom = reduce(system, order=5, modes=30, cache=tmp_path)
    y = rom.simulate({"fibre.k": 0.2, "fibre.c": 2e6}, np.array([1.0, 2.0])).as_array()
    rate = 200.0 / (2e6 * 4 * H)  # q / (c L)
    np.testing.assert_allclose(y[1] - y[0], rate, rtol=1e-4)


def test_thin_walls_all_modes_exact(tmp_path) -> None:
    # One-voxel fibre walls in gas (the wood cross-section): the basis stays independent, all modes exact.
    labels = np.zeros((6, 6, 6), dtype=int)
    labels[2, :, :] = 1
    labels[:, 3, :] = 1
    system = system_of(labels)
    rom = reduce(system, order=system.n, modes=system.n, cache=tmp_path)
    t = np.array([0.01, 0.4, 2.0])
    values = {"fibre.k": 1.0, "fibre.c": 1e7}
    exact = exact_outputs(system, values, t)
    np.testing.assert_allclose(rom.simulate(values, t).as_array(), exact, rtol=1e-7)


def test_steady_limit_matches_full_steady_solve(tmp_path) -> None:
    system = system_of(random_labels(5, seed=6))
    rom = reduce(system, order=system.n, modes=system.n, cache=tmp_path)
    _, e = system.observation_matrix()
    full = e @ steady_field(system, FAR)
    np.testing.assert_allclose(rom.steady(FAR)[0], full, rtol=1e-8)
    far_time = rom.simulate(FAR, np.array([1e6])).as_array()[0]
    np.testing.assert_allclose(far_time, full, rtol=1e-8)


_SWEEP_SYSTEM = system_of(random_labels(5, seed=7))
_SWEEP_ADIABATIC = system_of(random_labels(5, seed=7), [FaceSpec("z0", flux=500.0)])
_SWEEP: dict[str, ReducedModel] = {}


def _sweep_roms() -> tuple[ReducedModel, ReducedModel]:
    if not _SWEEP:
        _SWEEP["convective"] = reduce(_SWEEP_SYSTEM, order=60, modes=_SWEEP_SYSTEM.n, cache=False)
        _SWEEP["adiabatic"] = reduce(_SWEEP_ADIABATIC, order=60, modes=_SWEEP_SYSTEM.n, cache=False)
    return _SWEEP["convective"], _SWEEP["adiabatic"]


@settings(max_examples=10, deadline=None)
@given(k_ratio=st.floats(-3.0, 3.0), c_ratio=st.floats(-4.0, 4.0))
def test_contrast_sweep_is_stable_and_conservative(k_ratio: float, c_ratio: float) -> None:
    # k_F/k_G from 1e-3 to 1e3 and c_F/c_G from 1e-4 to 1e4, far from the reference values of basis and amalgam.
    rom, adiabatic = _sweep_roms()
    values = {"fibre.k": 0.025 * 10**k_ratio, "fibre.c": 1.2e3 * 10**c_ratio}
    rates = rom.rates(values)[0]  # Cholesky of L succeeded: the reduced pencil is positive definite
    assert np.all(rates >= 0.0) and rates[0] > 0  # no growing mode; convection removes the zero rate
    assert np.all(adiabatic.rates(values)[0] >= 0.0)
    t = np.array([0.02, 0.2, 2.0])
    y = rom.simulate(values, t).as_array()
    exact = exact_outputs(_SWEEP_SYSTEM, values, t)
    assert np.all(np.isfinite(y))
    # bounded error at order 60 of 216 (measured: ≤ 1.7 % for k ratios ≥ 0.1, 16 % at k ratio 1e-3)
    assert np.abs(y - exact).max() <= 0.25 * np.abs(exact).max()
    # energy balance, exact for a Galerkin model with the constant in its span:
    # steady state: all the heat entering z0 leaves through z1, h A <T>_z1 = q A;
    np.testing.assert_allclose(rom.steady(values)[0, 1], 500.0 / 20.0, rtol=1e-8)
    # adiabatic: the stored heat is q A t at every time.
    tt = np.array([0.0, 0.01, 0.5, 2.0])
    np.testing.assert_allclose(energy(adiabatic, values, tt), 500.0 * (5 * H) ** 2 * tt, rtol=1e-8, atol=1e-20)


def test_pod_baseline_same_order_reproduces_its_snapshots(tmp_path) -> None:
    system = system_of(random_labels(4, seed=8))
    pod = reduce(system, order=10, modes=system.n, method="pod", cache=tmp_path)
    assert pod.order == 10 and pod.info["method"] == "pod"
    t = system.time.times
    exact = exact_outputs(system, {"fibre.k": 0.1, "fibre.c": 1.2e6}, t)  # a snapshot case [Chavez2020, § 3.2]
    assert np.abs(pod.simulate({"fibre.k": 0.1, "fibre.c": 1.2e6}, t).as_array() - exact).max() < (
        1e-3 * np.abs(exact).max())


def test_amalgam_recovers_exact_groups() -> None:
    # States that are exact multiples of three principal histories are grouped without loss (eq. 9).
    rng = np.random.default_rng(0)
    heads = rng.normal(size=(3, 50))
    heads[0] = 1.0  # the constant mode
    alpha = np.array([0.5, -0.2, 0.1, 0.3])
    states = np.vstack([heads, alpha[:2, None] * heads[1], alpha[2:, None] * heads[2]])
    result = amalgam(states, 3, forced=[0])
    a = result.coefficients
    assert a.shape == (7, 3)
    np.testing.assert_array_equal(result.principal, [0, 1, 2])
    np.testing.assert_allclose(a[3:5, 1], alpha[:2])
    np.testing.assert_allclose(a[5:, 2], alpha[2:])
    assert np.count_nonzero(a[:, 0]) == 1  # constant alone in its group
    assert np.all(np.count_nonzero(a, axis=1) == 1)  # disjoint groups, every mode used once
    y = heads[[0, 1, 2]]
    np.testing.assert_allclose(a @ y, states, atol=1e-12)


def test_fixed_temperatures_are_lifted_not_projected(tmp_path) -> None:
    """A fixed face is lifted by reduce (tests/test_lifting.py checks the accuracy); projecting the system
    itself is refused.  The mean of the fixed face is its temperature exactly, at any order."""
    system = system_of(random_labels(3), [FaceSpec("z0", flux=1.0), FaceSpec("z1", T=20.0)])
    with pytest.raises(InputError, match="lifted"):
        ReducedModel.from_system(system, np.eye(system.n))
    rom = reduce(system, order=5, cache=tmp_path)
    assert rom.info["lifted_faces"] == 1
    np.testing.assert_allclose(rom.simulate({"z1.T": 7.0}).mean_T["z1"], 7.0, rtol=1e-14)


def test_correction_modes_make_the_steady_state_exact_at_their_samples(tmp_path) -> None:
    # With correction modes, the static responses K(s)⁻¹U at the samples s lie in the basis: the Galerkin
    # steady state is then the full one there (k_F = 0.53 × 0.1), whatever the (small) order.
    system = system_of(random_labels(6, seed=9))
    _, e = system.observation_matrix()
    sample = {"fibre.k": 0.53 * 0.1, "fibre.c": 4e6}
    full = e @ steady_field(system, sample)
    basis = {"fibre.k": 0.53}  # the correction samples are the basis values and 0.1×, 3× each conductivity
    rom = reduce(system, order=30, modes=60, basis_values=basis, cache=tmp_path)
    assert int(rom.info["n_corrections"]) > 0
    np.testing.assert_allclose(rom.steady(sample)[0], full, rtol=1e-9)
    seed_only = reduce(system, order=30, modes=60, basis_values=basis, corrections=False, cache=tmp_path)
    assert np.abs(seed_only.steady(sample)[0] - full).max() > 1e3 * np.abs(rom.steady(sample)[0] - full).max()


def test_cli_reduce_json_and_cache(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from aromm.cli import main

    np.savez(tmp_path / "img.npz", labels=random_labels(4, seed=10))
    scene = tmp_path / "s1.toml"
    scene.write_text(scenario_1("img.npz", "5.0e-6", "2.0", "0.1"))
    args = ["reduce", str(scene), "--order", "12", "--modes", "40", "--cache-dir", str(tmp_path / "cache"), "--json"]
    assert main(args) == 0
    first = json.loads(capsys.readouterr().out)
    assert first["order"] == 12 and first["cached"] == 0 and first["outputs"] == ["z0", "z1"]
    assert main(args) == 0
    assert json.loads(capsys.readouterr().out)["cached"] == 1
    assert main(["reduce", str(tmp_path / "missing.toml"), "--order", "5"]) == 2


class SlowestModes:
    """A reductor written outside aromm (modal truncation): the constants and the slowest other modes."""

    name = "slowest"

    def coefficients(self, detailed, order: int) -> np.ndarray:
        zero = detailed.basis.zero_modes
        rates = np.where(np.isnan(detailed.basis.eigenvalues), np.inf, detailed.basis.eigenvalues)
        others = [i for i in np.argsort(rates, kind="stable") if i not in set(zero)]
        keep = [*zero, *others[: order - zero.size]]
        return np.eye(detailed.size)[:, keep]


def test_a_reductor_from_outside_plugs_in_and_conserves_energy(tmp_path) -> None:
    # Any reductor that keeps the constant mode conserves the stored heat of an adiabatic body heated by q:
    # 1ᵀ C T̃ = q A t exactly, whatever else it drops.
    n, q = 5, 500.0
    system = system_of(random_labels(n, seed=5), [FaceSpec("z0", flux=q)], end=4.0)
    rom = reduce(system, order=6, modes=40, method=SlowestModes(), cache=tmp_path)
    assert rom.order == 6 and rom.info["method"] == "slowest"
    t = np.linspace(0.0, 4.0, 9)
    np.testing.assert_allclose(energy(rom, {}, t), q * (n * H) ** 2 * t, rtol=1e-9, atol=1e-18)
    with pytest.raises(InputError, match="Reductor"):
        reduce(system, order=6, modes=40, method=object(), cache=tmp_path)  # type: ignore[arg-type]
