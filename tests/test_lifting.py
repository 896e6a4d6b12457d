"""Fixed temperatures in the reduced model by lifting (issue 14 item 2): the homogeneous slab between fixed
temperatures against [Hassan2019, eq. 12–13], moving temperatures against an independent 1-D solution
(tests/slab1d.py), a two-phase body against the full model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from slab1d import Slab, solve

from aromm.core.errors import InputError
from aromm.core.profiles import Profile
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.analytic import slab_dirichlet_series
from aromm.full.solve import transient
from aromm.reduction.lifting import lift
from aromm.reduction.modal_bases import compute_basis
from aromm.reduction.offline import reduce
from aromm.reduction.rom import from_arrays, to_arrays

L, K, C = 0.1, 33.0, 7800.0 * 900.0  # [Hassan2019]'s steel slab: 0.1 m, 33 W/(m K), rho c = 7.02e6 J/(m3 K)
ALPHA = K / C
TAU = L**2 / ALPHA
TIMES = np.array([0.02, 0.05, 0.1, 0.2]) * TAU  # after the initial jump has spread over a few elements
MOVING = Profile((0.0, 0.02 * TAU, 0.05 * TAU), (25.0, 100.0, 60.0))


def slab(nz: int, right: float | Profile = 100.0) -> ThermalSystem:
    """The 1 × 1 × nz voxel slab, T = 25 °C on z0 and ``right`` on z1, T0 = 25 °C; outputs: the temperature
    of every node plane (observation rows built here, one per depth z_k = k L / nz)."""
    system = assemble_voxels(np.zeros((1, 1, nz), dtype=int), (L, L, L / nz), [PhaseSpec("steel", 0, K, C)],
                             [FaceSpec("z0", T=25.0), FaceSpec("z1", T=right)],
                             time=TimeGrid(0.2 * TAU, 0.2 * TAU / 800), initial_T=25.0)
    rows = {}
    for k in range(nz + 1):
        row = np.zeros(system.n)
        row[4 * k: 4 * k + 4] = 0.25  # the four nodes of plane k (x fastest, then y)
        rows[f"plane{k}"] = row
    return dataclasses.replace(system, observation=rows)


def test_lifted_system_reproduces_the_original_exactly() -> None:
    """The lifting is an exact change of unknowns: the full solver on the lifted system (free unknowns, lifting
    loads, initial field, feedthrough) gives the original outputs to round-off, for two fixed faces sharing an
    edge and a convective face, at parameters other than the lifting's reference values."""
    labels = np.random.default_rng(0).integers(0, 2, (3, 3, 4))
    phases = [PhaseSpec("a", 0, 0.3, 4e6), PhaseSpec("b", 1, 0.05, 1e6)]
    system = assemble_voxels(labels, (1e-4,) * 3, phases,
                             [FaceSpec("z0", T=12.0), FaceSpec("x1", T=5.0), FaceSpec("z1", h=20.0, T_ext=2.0)],
                             time=TimeGrid(20.0, 0.5), initial_T=3.0, outputs=["z0", "z1", "y0"])
    lifted = lift(system, {"a.k": 0.2, "b.c": 2e6})
    assert not lifted.dirichlet and lifted.n < system.n
    values = {"a.k": 0.5, "b.k": 0.01, "z0.T": 30.0, "initial.T": -1.0}
    for scheme in ("euler", "bdf2"):
        np.testing.assert_allclose(transient(lifted, values, scheme=scheme).as_array(),
                                   transient(system, values, scheme=scheme).as_array(), atol=1e-11)


def test_lifted_basis_has_no_constant_and_vanishes_on_the_fixed_face() -> None:
    """The Steklov modes of the lifted system live on the free unknowns (zero on the fixed face) and are
    discretely harmonic; the constant is no mode (it does not vanish on the fixed face)."""
    lifted = lift(slab(8))
    basis = compute_basis(lifted, 4, 6)
    assert basis.count("zero") == 0 and basis.count("steklov") == 6
    free = lifted.conductance.evaluate(lifted.parameters)
    interior = np.flatnonzero(lifted.boundary.diagonal() == 0)  # type: ignore[union-attr]
    steklov = basis.vectors[:, basis.kinds == "steklov"]
    assert np.abs((free @ steklov)[interior]).max(initial=0.0) < 1e-10 * np.abs(free @ steklov).max()


def test_reduced_slab_between_fixed_temperatures_matches_the_series() -> None:
    """[Hassan2019, eq. 12–13]: the reduced model (exact in time) differs from the series by the spatial
    discretisation error only: second order in dz (within the full model's own error at that mesh, whose
    BDF2 error is 1e-3 K), and equals the exact semi-discrete 1-D solution (no reduction error here)."""
    errors = []
    for nz in (8, 16):
        system = slab(nz)
        z = np.arange(nz + 1) * L / nz
        series = slab_dirichlet_series(z[None, :], TIMES[:, None], L, ALPHA, 25.0, 25.0, 100.0, n_terms=400)
        semi = solve(Slab(np.full(nz, K), np.full(nz, C), L / nz), TIMES, fixed_first=lambda t: 25.0,
                     fixed_last=lambda t: 100.0, initial=25.0)
        rom = reduce(system, order=nz, cache=False)
        y = rom.simulate(times=TIMES).as_array()
        # the slab's response lives in its nz − 1 free planes ≤ order: no reduction error (measured 6e-9 K)
        assert np.abs(y - semi).max() < 1e-6, np.abs(y - semi).max()
        full = transient(system, times=TIMES).as_array()
        errors.append(np.abs(y - series).max())
        assert errors[-1] < 1.05 * np.abs(full - series).max() + 0.05
    assert np.log2(errors[0] / errors[1]) > 1.6, errors  # measured 1.76 (2.0 K → 0.59 K; 1.77 for the full model)
    complete = reduce(slab(8), order=100, modes=100, cache=False).simulate(times=TIMES).as_array()
    semi = solve(Slab(np.full(8, K), np.full(8, C), L / 8), TIMES, fixed_first=lambda t: 25.0,
                 fixed_last=lambda t: 100.0, initial=25.0)
    np.testing.assert_allclose(complete, semi, atol=1e-9)


def test_moving_fixed_temperature_is_reduced_exactly() -> None:
    """A fixed temperature ramped up then down (history on z1): the lifting carries g and its piecewise-constant
    derivative; the complete basis equals the exact 1-D solution to round-off, order 8 to its reduction error."""
    nz = 16
    system = slab(nz, MOVING)
    semi = solve(Slab(np.full(nz, K), np.full(nz, C), L / nz), TIMES, fixed_first=lambda t: 25.0,
                 fixed_last=lambda t: float(MOVING(t)), initial=25.0, breaks=MOVING.times)
    rom = reduce(system, order=8, cache=False)
    assert np.abs(rom.simulate(times=TIMES).as_array() - semi).max() < 0.05  # measured 5e-3 K
    complete = reduce(system, order=100, modes=100, cache=False)
    np.testing.assert_allclose(complete.simulate(times=TIMES).as_array(), semi, atol=1e-9)
    restored = from_arrays(to_arrays(rom))
    np.testing.assert_array_equal(restored.simulate(times=TIMES).as_array(), rom.simulate(times=TIMES).as_array())


def test_two_phase_body_with_a_fixed_face_agrees_with_the_full_model() -> None:
    """Flux pulse on z0, fixed 20 °C on z1 (from T0 = 20 °C, no initial jump), contrast 6: the reduced model
    agrees with the refined full model within the usual reduced-model error, also away from the reference
    values of the lifting and at another fixed temperature."""
    labels = np.random.default_rng(0).integers(0, 2, (4, 4, 6))
    pulse = Profile((0.0, 2.0, 4.0), (0.0, 500.0, 0.0))
    system = assemble_voxels(labels, (1e-4,) * 3, [PhaseSpec("a", 0, 0.3, 4e6), PhaseSpec("b", 1, 0.05, 1e6)],
                             [FaceSpec("z0", flux=pulse), FaceSpec("z1", T=20.0)], time=TimeGrid(20.0, 0.005),
                             initial_T=20.0, outputs=["z0", "z1", "x1"])
    rom = reduce(system, order=40, cache=False)
    t = np.linspace(0.1, 20.0, 100)
    for values in ({}, {"a.k": 0.5, "b.c": 2e6}, {"z1.T": 25.0}):
        full = transient(system, values, times=t).as_array()
        error = np.abs(rom.simulate(values, t).as_array() - full).max()
        assert error < 0.01 * np.ptp(full), (values, error)  # measured 1e-4 – 1e-3 of the range


def test_reference_cases_must_fix_the_same_faces() -> None:
    with pytest.raises(InputError, match="same faces"):
        reduce(slab(4), order=4, references=[dataclasses.replace(slab(4), dirichlet=())], cache=False)
