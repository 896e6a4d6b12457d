"""Coupled heat and moisture (aromm.physics.hygrothermal) against independent truths: the exact solution of the
coupled 1-D slab (the 2 × 2 diffusion matrix diagonalised, one Fourier series per mode), the decoupled limit
(δ_p = 0: the thermal model unchanged), and the symmetry and definiteness the solvers rely on."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from aromm.core.errors import InputError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.exact import exact_outputs
from aromm.physics.hygrothermal import MoistureState, coupled, p_sat, p_sat_slope
from aromm.reduction.lifting import lift

#: A wood-fibre board about 20 °C, 50 % RH (orders of magnitude of the literature, e.g. [Kuenzel1995]): k, ρ c_p,
#: ξ = dw/dφ, D_φ and δ_p (vapour diffusion resistance μ ≈ 10).
BOARD = {"k": 0.04, "c": 3.2e5, "xi": 20.0, "D_phi": 1.0e-9, "delta_p": 2.0e-11}
STATE = MoistureState(T_ref=20.0, phi_ref=0.5)
LENGTH = 0.02  # m
TIMES = np.array([600.0, 1800.0, 3600.0, 7200.0])  # s


def _slab(cells: int, delta_p: float = BOARD["delta_p"], assemble=assemble_voxels):  # type: ignore[no-untyped-def]
    """A bar of ``cells`` voxels along x: T fixed at 20 °C and φ at 0.8 on x0 (a humidity step), x1 adiabatic and
    sealed; the coupled system and its thermal part (``assemble``: Q1 elements, or finite volumes)."""
    labels = np.zeros((cells, 1, 1), dtype=int)
    size = LENGTH / cells
    thermal = assemble(labels, (size, size, size), [PhaseSpec("board", 0, BOARD["k"], BOARD["c"])],
                              [FaceSpec("x0", T=20.0)], time=TimeGrid(TIMES[-1], 600.0), initial_T=20.0,
                              outputs=["x1"])
    moisture = {"board": {"xi": BOARD["xi"], "D_phi": BOARD["D_phi"], "delta_p": delta_p}}
    return coupled(thermal, STATE, moisture, fixed_phi={"x0": 0.8}, initial_phi=0.5), thermal


def _exact_far_face(times: np.ndarray, terms: int = 4000) -> np.ndarray:
    """(T, φ) at x = L of the homogeneous slab: ``diag(c, λξ) u_t = A u_xx`` with A the symmetrised flux matrix,
    u = (T − 20, φ − 0.5), u(0, t) = (0, 0.3), u_x(L, t) = 0, u(x, 0) = 0.  With ``A w = μ C w``, ``WᵀCW = I``, the
    modes s = WᵀC u each solve ``s_t = μ s_xx``:
    s(L, t) = s₀ (1 − Σ_m 4/((2m+1)π) (−1)^m e^{−μ (2m+1)² π² t / (4L²)})."""
    lam, a, p, lv = STATE.weight, STATE.a, STATE.p, STATE.latent_heat
    k, d, dp = BOARD["k"], BOARD["D_phi"], BOARD["delta_p"]
    flux = np.array([[k + lv * dp * a, lv * dp * p], [lv * dp * p, lam * (d + dp * p)]])
    cap = np.diag([BOARD["c"], lam * BOARD["xi"]])
    mu, w = sla.eigh(flux, cap)  # wᵀ cap w = I
    s0 = w.T @ cap @ np.array([0.0, 0.3])
    m = np.arange(terms)
    odd = (2 * m + 1) * np.pi
    out = np.zeros((times.size, 2))
    for i, t in enumerate(times):
        decay = np.exp(-np.outer(mu, odd**2) * t / (4 * LENGTH**2))  # (2 modes, terms)
        series = (4 / odd * (-1.0) ** m * decay).sum(axis=1)
        out[i] = w @ (s0 * (1 - series))
    return out + np.array([20.0, 0.5])


def _far_face(system, values=None) -> np.ndarray:  # type: ignore[no-untyped-def]
    lifted = lift(system)
    y = exact_outputs(lifted, dict(values or {}), TIMES)
    names = list(lifted.observation)
    return np.stack([y[:, names.index("x1")], y[:, names.index("phi:x1")]], axis=1)


def test_the_linearisation_constants() -> None:
    """p_sat within 0.2 % of the IAPWS-95 saturation pressures (Tetens' formula is that close between 0 and 50 °C):
    611.2 Pa at 0 °C, 2339.2 Pa at 20 °C, 7384.9 Pa at 40 °C; its slope against a centred difference; λ makes the
    off-diagonal flux terms equal (L_v δ_p p = λ δ_p a)."""
    for t, iapws in ((0.0, 611.2), (20.0, 2339.2), (40.0, 7384.9)):
        assert p_sat(t) == pytest.approx(iapws, rel=2e-3)
    h = 1e-3
    assert p_sat_slope(20.0) == pytest.approx((p_sat(20.0 + h) - p_sat(20.0 - h)) / (2 * h), rel=1e-6)
    assert STATE.weight * STATE.a == pytest.approx(STATE.latent_heat * STATE.p, rel=1e-14)


def test_the_coupled_slab_converges_to_the_exact_solution_at_second_order() -> None:
    """Q1 on the bar, exact in time: the far face's T and φ against the two-mode Fourier solution; the error falls
    by about 4 per halving of the cells (second order in space)."""
    exact = _exact_far_face(TIMES)
    errors = []
    for cells in (8, 16, 32):
        errors.append(np.abs(_far_face(_slab(cells)[0]) - exact).max(axis=0))
    errors_arr = np.array(errors)
    assert np.all(errors_arr[-1] < np.array([2e-4, 2e-4])), errors_arr  # °C and RH (0–1)
    rates = np.log2(errors_arr[:-1] / errors_arr[1:])
    assert np.all(rates > 1.8), rates
    # the coupling is seen: the humidity step warms the far face (sorption heat) by more than the error
    assert exact[:, 0].max() - 20.0 > 100 * errors_arr[-1, 0]


def test_the_coupled_slab_in_finite_volumes_converges_at_second_order() -> None:
    """The same bar in finite volumes (the fixed face half a cell from the first centre, the far face an output
    unknown): second order too, with errors of the size of Q1's."""
    from aromm.fv.volumes import assemble_volumes

    exact = _exact_far_face(TIMES)
    errors = np.array([np.abs(_far_face(_slab(cells, assemble=assemble_volumes)[0]) - exact).max(axis=0)
                       for cells in (8, 16, 32)])
    assert np.all(errors[-1] < np.array([2e-4, 2e-4])), errors  # °C and RH (0–1)
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all(rates > 1.8), rates


def test_without_vapour_transport_the_heat_equation_is_the_thermal_model() -> None:
    """δ_p = 0 uncouples the fields: the T block equals the thermal system's own outputs (to the rounding of two
    dense eigendecompositions), whatever φ does."""
    system, thermal = _slab(8, delta_p=0.0)
    t_coupled = _far_face(system)[:, 0]
    t_thermal = exact_outputs(lift(thermal), {}, TIMES)[:, list(thermal.observation).index("x1")]
    assert np.abs(t_coupled - t_thermal).max() <= 1e-9 * 20.0


def test_the_coupled_operators_are_symmetric_and_semi_definite() -> None:
    system, _ = _slab(6)
    values = system.values()
    for affine in (system.conductance, system.capacity):
        a = affine.evaluate(values).toarray()
        assert np.abs(a - a.T).max() <= 1e-14 * np.abs(a).max()
        eig = np.linalg.eigvalsh(a)
        assert eig.min() >= -1e-12 * eig.max()
    assert {"board.xi", "board.D_phi", "board.delta_p", "x0.phi", "initial.phi"} <= set(system.parameter_names)


def test_bad_moisture_input_is_refused_with_its_name() -> None:
    _, thermal = _slab(4)
    with pytest.raises(InputError, match="no moisture properties for phase"):
        coupled(thermal, STATE, {})
    with pytest.raises(InputError, match=r"board\.delta_p must be a finite value"):
        coupled(thermal, STATE, {"board": {"xi": 1.0, "D_phi": 0.0, "delta_p": -1.0}})
    with pytest.raises(InputError, match="neither a face with a fixed temperature nor an output face"):
        coupled(thermal, STATE, {"board": {"xi": 1.0, "D_phi": 0.0, "delta_p": 0.0}}, fixed_phi={"z1": 0.5})
    with pytest.raises(InputError, match="phi_ref must lie"):
        MoistureState(phi_ref=0.0)


@pytest.mark.filterwarnings("ignore::aromm.core.errors.ModelWarning")
def test_the_krylov_reduced_model_and_its_certified_bound_apply_unchanged() -> None:
    """The coupled system is an affine system of the thermal kind: the Krylov reductor over (ξ, δ_p) builds its
    model, whose certified bound holds against the exact full model at points inside the box (initial φ ≠ initial
    T, so the model's own initial terms are exercised)."""
    from aromm.api import reduce

    system, _ = _slab(16)
    rom = reduce(system, 40, method="krylov", bounds={"board.xi": (10.0, 40.0), "board.delta_p": (1e-11, 4e-11)},
                 cache=False)
    assert system.time is not None
    times = system.time.times
    for mu in ({"board.xi": 15.0, "board.delta_p": 3e-11}, {"board.xi": 35.0, "board.delta_p": 1.5e-11}):
        truth = exact_outputs(lift(system), mu, times)
        actual = np.abs(rom.simulate(mu, times).as_array() - truth).max(axis=0)
        bound = rom.error_bound(mu)
        assert bound is not None
        assert np.all(bound >= actual - 1e-11 * np.abs(truth).max()), (bound, actual)
    with pytest.raises(InputError, match=r"unknown parameter 'board\.xii'"):  # initial.phi is known, a typo is not
        rom.error_bound({"board.xii": 15.0})


def test_vapour_exchange_gives_the_exact_steady_profile() -> None:
    """Steady bar: T = 20 °C and φ = 0.8 fixed on x0; on x1 convection (h 8 W/(m² K), T_ext 18 °C) and vapour
    exchange (β 2e-8 kg/(m² s Pa), φ_ext 0.4) with the same air (near the reference state: the linearisation of
    p_v is the model's, and far from (T_ref, φ_ref) it stops being the physics).  The exact solution is linear,
    u = u0 + s x with (A + H L) s = −H (u0 − u_ext) (A the symmetrised flux matrix, H the exchange rows: heat
    h(T − T_ext) plus the latent heat L_v j, moisture λ j, j = β (p (φ − φ_ext) + a (T − T_ext))); Q1 reproduces a
    linear field exactly, so the far face agrees to the direct solve's rounding."""
    from aromm.full.solve import steady_field

    size = LENGTH / 6
    thermal = assemble_voxels(np.zeros((6, 1, 1), dtype=int), (size, size, size),
                              [PhaseSpec("board", 0, BOARD["k"], BOARD["c"])],
                              [FaceSpec("x0", T=20.0), FaceSpec("x1", h=8.0, T_ext=18.0)], outputs=["x1"])
    moisture = {"board": {k: BOARD[k] for k in ("xi", "D_phi", "delta_p")}}
    system = coupled(thermal, STATE, moisture, fixed_phi={"x0": 0.8}, vapour={"x1": (2e-8, 0.4)})
    field = steady_field(system)
    far = np.array([float(np.asarray(system.observation[name] @ field).ravel()[0]) for name in ("x1", "phi:x1")])
    lam, a, p, lv = STATE.weight, STATE.a, STATE.p, STATE.latent_heat
    k, d, dp, beta = BOARD["k"], BOARD["D_phi"], BOARD["delta_p"], 2e-8
    flux = np.array([[k + lv * dp * a, lv * dp * p], [lv * dp * p, lam * (d + dp * p)]])
    h = np.array([[8.0 + lv * beta * a, lv * beta * p], [lam * beta * a, lam * beta * p]])
    u0, u_ext = np.array([20.0, 0.8]), np.array([18.0, 0.4])
    s = -np.linalg.solve(flux + h * LENGTH, h @ (u0 - u_ext))
    exact = u0 + s * LENGTH
    assert np.abs(far - exact).max() <= 1e-9 * np.abs(exact).max()
    with pytest.raises(InputError, match="needs the face to exchange heat with the same air"):
        coupled(thermal, STATE, moisture, vapour={"x0": (2e-8, 0.3)})


def _physical(state: MoistureState, k: float, d: float, dp: float) -> np.ndarray:
    """A phase's flux matrix in physical units: heat and moisture fluxes against (∇T, ∇φ)."""
    lv, a, p = state.latent_heat, state.a, state.p
    return np.array([[k + lv * dp * a, lv * dp * p], [dp * a, d + dp * p]])


def test_the_homogenised_moisture_transport_of_a_laminate_is_its_exact_means() -> None:
    """Two phases in layers across x: along y and z the effective matrix is the volume mean of the phases' matrices,
    across x their matrix harmonic mean (of the symmetrised matrices: diag(1, λ) times the physical ones), both
    exact for Q1 on layers that follow the voxel faces; ξ̄ is the volume mean (the direct solves' rounding)."""
    from aromm.homogenization.moisture_cells import mean_moisture_capacity, moisture_transport
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.moisture_section import MoistureScene
    from aromm.scene.scene_file import Scene

    labels = np.zeros((4, 3, 3), dtype=int)
    labels[2:] = 1
    props = {"wall": (0.3, 2e-9, 1e-13, 200.0), "air": (0.025, 0.0, 2e-10, 0.017)}
    phases = (PhaseSpec("wall", 0, props["wall"][0], 1e6), PhaseSpec("air", 1, props["air"][0], 1.2e3))
    moisture = MoistureScene(STATE, {n: {"D_phi": v[1], "delta_p": v[2], "xi": v[3]} for n, v in props.items()},
                             {}, 0.5)
    scene = Scene(VoxelGeometry(labels, (1e-5, 1e-5, 1e-5)), phases, moisture=moisture)  # type: ignore[arg-type]
    found = moisture_transport(scene)
    weight = np.diag([1.0, STATE.weight])
    sym = [weight @ _physical(STATE, *v[:3]) for v in props.values()]
    series = np.linalg.inv(weight) @ np.linalg.inv((np.linalg.inv(sym[0]) + np.linalg.inv(sym[1])) / 2)
    parallel = np.linalg.inv(weight) @ ((sym[0] + sym[1]) / 2)
    for axis, expect in ((0, series), (1, parallel), (2, parallel)):
        assert np.allclose(found[axis], expect, rtol=1e-9, atol=1e-12 * np.abs(expect).max()), (axis, found[axis])
    assert mean_moisture_capacity(scene) == pytest.approx((200.0 + 0.017) / 2, rel=1e-14)


def test_the_fixed_value_probe_drops_the_scenes_own_conditions() -> None:
    """The probe's other faces are adiabatic and sealed whatever the scene sets there: a moisture flux, vapour exchange
    and face conditions of the scene (tests/petsc_moisture_cases.py's: a flux of water on z1 among them) leave the
    matrix unchanged (the flux used to stay in the x and y probes and load them)."""
    from dataclasses import replace as swap

    import petsc_moisture_cases as cases

    from aromm.homogenization.moisture_cells import moisture_transport

    scene = cases.steady_scene()
    assert scene.moisture is not None and scene.moisture.flux and scene.moisture.vapour
    bare = swap(scene, boundary=(), moisture=swap(scene.moisture, flux={}, vapour={}, fixed_phi={}, outputs=()),
                outputs=())
    np.testing.assert_array_equal(moisture_transport(scene, "splu"), moisture_transport(bare, "splu"))


def test_a_moisture_flux_gives_the_exact_steady_profile() -> None:
    """Steady bar: T = 20 °C and φ = 0.8 fixed on x0; on x1 a moisture flux g = 2e-7 kg/(m² s) enters, heat
    adiabatic.  The fluxes are uniform: no heat (q = 0) and the water g flowing back to x0, so the profile is linear
    with slopes s solving F s = (0, g) in physical units (F the phases' flux matrix: q = −F₀· ∇u, m = −F₁· ∇u);
    Q1 reproduces a linear field exactly."""
    from aromm.full.solve import steady_field

    size = LENGTH / 6
    thermal = assemble_voxels(np.zeros((6, 1, 1), dtype=int), (size, size, size),
                              [PhaseSpec("board", 0, BOARD["k"], BOARD["c"])], [FaceSpec("x0", T=20.0)],
                              outputs=["x1"])
    moisture = {"board": {k: BOARD[k] for k in ("xi", "D_phi", "delta_p")}}
    g = 2e-7
    system = coupled(thermal, STATE, moisture, fixed_phi={"x0": 0.8}, moisture_flux={"x1": (g, size * size)})
    field = steady_field(system)
    far = np.array([float(np.asarray(system.observation[name] @ field).ravel()[0]) for name in ("x1", "phi:x1")])
    physical = _physical(STATE, BOARD["k"], BOARD["D_phi"], BOARD["delta_p"])
    slope = np.linalg.solve(physical, np.array([0.0, g]))  # −F s = (q, m) = (0, −g)
    exact = np.array([20.0, 0.8]) + slope * LENGTH
    assert exact[1] > 0.8 + 1e-3 and abs(exact[0] - 20.0) > 1e-4  # wetter, and T moved by the vapour's latent heat
    assert np.abs(far - exact).max() <= 1e-9 * np.abs(exact).max()
    with pytest.raises(InputError, match=r"x0\.g needs a face-mean output of x0"):
        coupled(thermal, STATE, moisture, moisture_flux={"x0": (g, size * size)})


def test_an_orthotropic_phase_uniform_across_the_field_is_the_isotropic_one() -> None:
    """A plate held at (20 °C, 0.8) on x0 and y0 varies in x and y, not in z: an orthotropic board k = (0.04, 0.04,
    0.7) W/(m K) gives the isotropic board's far face (k = 0.04) exactly in time, T and φ, to the dense solutions'
    rounding.  D_φ and δ_p must act on the sum of the phase's axis operators (the isotropic one): on the x operator
    alone, the humidity would not spread along y."""
    def far(k: float | tuple[float, float, float]) -> np.ndarray:
        size = LENGTH / 6
        thermal = assemble_voxels(np.zeros((6, 6, 1), dtype=int), (size, size, size),
                                  [PhaseSpec("board", 0, k, BOARD["c"])],
                                  [FaceSpec("x0", T=20.0), FaceSpec("y0", T=20.0)], time=TimeGrid(TIMES[-1], 600.0),
                                  initial_T=20.0, outputs=["x1"])
        moisture = {"board": {key: BOARD[key] for key in ("xi", "D_phi", "delta_p")}}
        return _far_face(coupled(thermal, STATE, moisture, fixed_phi={"x0": 0.8, "y0": 0.8}, initial_phi=0.5))

    iso, ortho = far(BOARD["k"]), far((BOARD["k"], BOARD["k"], 0.7))
    assert np.abs(iso[:, 0] - 20.0).max() > 0.1  # the sorption heat shows
    assert np.abs(ortho - iso).max() <= 1e-9 * np.abs(iso).max()


def test_the_flux_probe_of_the_moisture_transport() -> None:
    """The flux probe ([Chavez2020, eq. 13] for both fields): across the layers of a laminate it is the exact
    matrix-harmonic mean (as the fixed-value probe); without vapour transport (δ_p = 0) it is, entry by entry, the
    thermal flux probe of the image with the phases' k, then with their D_φ as conductivities (along the layers too,
    where the flux probe is not the arithmetic mean)."""
    from dataclasses import replace as swap

    from aromm.homogenization.cell_problems import effective_conductivity
    from aromm.homogenization.moisture_cells import moisture_transport
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.moisture_section import MoistureScene
    from aromm.scene.scene_file import Scene

    labels = np.zeros((4, 3, 3), dtype=int)
    labels[2:] = 1
    props = {"wall": (0.3, 2e-9, 1e-13, 200.0), "air": (0.025, 5e-10, 2e-10, 0.017)}

    def scene(delta: bool, k_of: int = 0) -> Scene:
        phases = tuple(PhaseSpec(n, i, v[k_of], 1e6) for i, (n, v) in enumerate(props.items()))
        moisture = MoistureScene(STATE, {n: {"D_phi": v[1], "delta_p": v[2] if delta else 0.0, "xi": v[3]}
                                         for n, v in props.items()}, {}, 0.5)
        return Scene(VoxelGeometry(labels, (1e-5, 1e-5, 1e-5)), phases, moisture=moisture)  # type: ignore[arg-type]

    coupled_flux, fixed = moisture_transport(scene(True), boundary="flux"), moisture_transport(scene(True))
    assert np.allclose(coupled_flux[0], fixed[0], rtol=1e-9, atol=1e-12 * np.abs(fixed[0]).max())  # series: exact
    decoupled = moisture_transport(scene(False), boundary="flux")
    thermal = np.diag(effective_conductivity(swap(scene(False), moisture=None), "flux", "splu").k)
    water = np.diag(effective_conductivity(swap(scene(False, k_of=1), moisture=None), "flux", "splu").k)
    assert thermal[1] < 0.9 * (0.3 + 0.025) / 2  # along the layers the flux probe is below the arithmetic mean
    for axis in range(3):
        assert decoupled[axis][0, 0] == pytest.approx(thermal[axis], rel=1e-9)
        assert decoupled[axis][1, 1] == pytest.approx(water[axis], rel=1e-9)
        assert abs(decoupled[axis][0, 1]) <= 1e-9 * decoupled[axis][0, 0]


def test_the_periodic_cell_of_the_moisture_transport() -> None:
    """The periodic cell of the coupled problem: on a laminate its diagonal blocks are the exact means (as the
    fixed-value probe: the arithmetic mean along the layers, the matrix-harmonic mean across) and its off-diagonal
    blocks vanish; without vapour transport (δ_p = 0) its heat block is, entry by entry and off the diagonal too, the
    thermal periodic tensor of the image (aromm.homogenization.cell_problems, another solver), and its moisture
    block the thermal one with the phases' D_φ as conductivities.  Tolerances: the direct solves' rounding."""
    from dataclasses import replace as swap

    from aromm.homogenization.cell_problems import effective_conductivity
    from aromm.homogenization.moisture_cells import moisture_transport, periodic_transport
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.moisture_section import MoistureScene
    from aromm.scene.scene_file import Scene

    props = {"wall": (0.3, 2e-9, 1e-13, 200.0), "air": (0.025, 5e-10, 2e-10, 0.017)}

    def scene(labels: np.ndarray, delta: bool = True, k_of: int = 0) -> Scene:
        phases = tuple(PhaseSpec(n, i, v[k_of], 1e6) for i, (n, v) in enumerate(props.items()))
        moisture = MoistureScene(STATE, {n: {"D_phi": v[1], "delta_p": v[2] if delta else 0.0, "xi": v[3]}
                                         for n, v in props.items()}, {}, 0.5)
        return Scene(VoxelGeometry(labels, (1e-5, 1e-5, 1e-5)), phases, moisture=moisture)  # type: ignore[arg-type]

    layers = np.zeros((4, 3, 3), dtype=int)
    layers[2:] = 1
    periodic, fixed = periodic_transport(scene(layers)), moisture_transport(scene(layers))
    for i in range(3):
        scale = np.abs(fixed[i]).max()
        assert np.allclose(periodic[i, i], fixed[i], rtol=1e-9, atol=1e-12 * scale), (i, periodic[i, i])
        for j in set(range(3)) - {i}:
            assert np.abs(periodic[i, j]).max() <= 1e-12 * scale
    rng = np.random.default_rng(3)
    grains = (rng.random((5, 4, 3)) < 0.45).astype(int)  # no symmetry: off-diagonal entries of order 1e-2 of k̄
    decoupled = periodic_transport(scene(grains, delta=False))
    thermal = effective_conductivity(swap(scene(grains, False), moisture=None), "periodic", "splu").k
    water = effective_conductivity(swap(scene(grains, False, k_of=1), moisture=None), "periodic", "splu").k
    assert np.abs(thermal - np.diag(np.diag(thermal))).max() > 1e-3 * thermal.max()
    assert np.allclose(decoupled[:, :, 0, 0], thermal, rtol=0, atol=1e-10 * thermal.max())
    assert np.allclose(decoupled[:, :, 1, 1], water, rtol=0, atol=1e-10 * water.max())
    assert np.abs(decoupled[:, :, 0, 1]).max() <= 1e-10 * thermal.max()
