"""Closed-form models of [GarnierDanes]: limits, reductions and orderings that theory fixes, over the whole domain."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aromm.bounds import models as m
from aromm.bounds.domain import PHI_MAX_SC, cell_B, cell_phi
from aromm.core.errors import InputError

PHI = st.floats(1e-6, PHI_MAX_SC)
KAPPA = st.floats(-4.0, 4.0).map(lambda e: 10.0**e)
CONTACT = st.one_of(st.just(0.0), st.floats(-8.0, 3.0).map(lambda e: 10.0**e))
XI = st.floats(0.0, 1.0)
RTOL = 1e-10  # the closed forms lose ~eps/E relative when E ~ 1e-4 (insulating fillers)

ALL_PHI_KAPPA = (m.wiener_parallel, m.wiener_series, m.maxwell_eucken, m.hashin_shtrikman_lower,
                 m.hashin_shtrikman_upper, m.hatta_taya, m.lewis_nielsen, m.hasselman_johnson,
                 m.torquato_rintoul_lower, m.torquato_rintoul_upper, m.rayleigh_simple_cubic)
WITH_CONTACT = (m.hasselman_johnson, m.torquato_rintoul_lower, m.torquato_rintoul_upper,
                m.rayleigh_simple_cubic)


def beran_milton(phi: float, kappa: float, zeta2: float) -> tuple[float, float]:
    """Third-order bounds written independently from effective_formulas.md §8 (matrix = phase 1)."""
    mean = 1 - phi + phi * kappa
    mean_t = phi + (1 - phi) * kappa
    z1 = 1 - zeta2
    jump = phi * (1 - phi) * (kappa - 1) ** 2
    upper = mean - jump / (mean_t + 2 * (z1 + zeta2 * kappa))
    lower = mean - jump / (mean_t + 2 / (z1 + zeta2 / kappa))
    return lower, upper


@settings(max_examples=300, deadline=None)
@given(PHI, KAPPA, CONTACT, XI)
def test_every_model_is_finite_and_positive(phi: float, kappa: float, c: float, xi: float) -> None:
    values = [f(phi, kappa) for f in ALL_PHI_KAPPA]
    values += [f(phi, kappa, c) for f in WITH_CONTACT]
    values += [m.torquato_rintoul_lower(phi, kappa, c, xi), m.torquato_rintoul_upper(phi, kappa, c, xi)]
    assert np.all(np.isfinite(values)) and np.all(np.asarray(values) > 0)


@settings(max_examples=300, deadline=None)
@given(PHI, KAPPA, XI)
def test_orderings_without_contact(phi: float, kappa: float, xi: float) -> None:
    """Wiener ⊃ Hashin-Shtrikman ⊃ Beran-Milton (0 <= zeta2 <= 1) for any isotropic microstructure."""
    ws, wp = m.wiener_series(phi, kappa), m.wiener_parallel(phi, kappa)
    hl, hu = m.hashin_shtrikman_lower(phi, kappa), m.hashin_shtrikman_upper(phi, kappa)
    tl, tu = m.torquato_rintoul_lower(phi, kappa, 0.0, xi), m.torquato_rintoul_upper(phi, kappa, 0.0, xi)
    tol = 1 + RTOL
    assert ws <= hl * tol and hl <= tl * tol and tl <= tu * tol and tu <= hu * tol and hu <= wp * tol
    assert hl <= m.maxwell_eucken(phi, kappa) * tol <= hu * tol**2


@settings(max_examples=200, deadline=None)
@given(PHI, KAPPA, CONTACT, XI)
def test_third_order_bounds_are_ordered_with_contact(phi: float, kappa: float, c: float, xi: float) -> None:
    assert m.torquato_rintoul_lower(phi, kappa, c, xi) <= m.torquato_rintoul_upper(phi, kappa, c, xi) * (1 + RTOL)


@settings(max_examples=200, deadline=None)
@given(PHI, KAPPA, XI)
def test_third_order_bounds_reduce_to_beran_milton_at_zero_contact(phi: float, kappa: float, xi: float) -> None:
    lower, upper = beran_milton(phi, kappa, xi)
    assert m.torquato_rintoul_lower(phi, kappa, 0.0, xi) == pytest.approx(lower, rel=1e-11)
    assert m.torquato_rintoul_upper(phi, kappa, 0.0, xi) == pytest.approx(upper, rel=1e-11)


@settings(max_examples=200, deadline=None)
@given(PHI, KAPPA, CONTACT)
def test_upper_third_order_bound_with_xi_zero_is_hasselman_johnson(phi: float, kappa: float, c: float) -> None:
    """effective_formulas.md §9 check 2 (verified symbolically there)."""
    assert m.torquato_rintoul_upper(phi, kappa, c, 0.0) == pytest.approx(
        m.hasselman_johnson(phi, kappa, c), rel=1e-10)


@pytest.mark.parametrize("model", ALL_PHI_KAPPA)
@pytest.mark.parametrize("phi", [1e-6, 0.2, PHI_MAX_SC])
def test_contrast_one_gives_exactly_one(model, phi: float) -> None:  # type: ignore[no-untyped-def]
    assert model(phi, 1.0) == 1.0


@pytest.mark.parametrize("model", [m.maxwell_eucken, m.hashin_shtrikman_lower, m.hashin_shtrikman_upper,
                                   m.torquato_rintoul_lower, m.torquato_rintoul_upper, m.hatta_taya,
                                   m.wiener_series, m.rayleigh_simple_cubic, m.hasselman_johnson])
@pytest.mark.parametrize("delta", [1e-9, -1e-9, 1e-6])
def test_near_contrast_one_first_order_term_without_cancellation(model, delta: float) -> None:  # type: ignore[no-untyped-def]
    """E = 1 + phi delta + O(delta^2) for every isotropic model: E - 1 keeps its digits (no 0/0)."""
    phi = 0.3
    e = model(phi, 1.0 + delta)
    assert (e - 1.0) / (phi * delta) == pytest.approx(1.0, abs=max(2 * abs(delta), 1e-6))


@settings(max_examples=200, deadline=None)
@given(PHI, KAPPA)
def test_hashin_shtrikman_matrix_bound_is_maxwell(phi: float, kappa: float) -> None:
    me = m.maxwell_eucken(phi, kappa)
    matrix_bound = m.hashin_shtrikman_lower(phi, kappa) if kappa >= 1 else m.hashin_shtrikman_upper(phi, kappa)
    assert matrix_bound == me
    # closed form of effective_formulas.md §3, written out
    assert me == pytest.approx((kappa + 2 + 2 * phi * (kappa - 1)) / (kappa + 2 - phi * (kappa - 1)), rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(PHI, KAPPA, CONTACT)
def test_hasselman_johnson_is_maxwell_with_dipole_conductivity(phi: float, kappa: float, c: float) -> None:
    kappa1 = 1.0 / (1.0 / kappa + c)
    assert m.hasselman_johnson(phi, kappa, c) == pytest.approx(m.maxwell_eucken(phi, kappa1), rel=1e-12)
    # the published form (effective_formulas.md §4) with lambda_p/(a h_c) = kappa C
    r = kappa * c
    published = ((2 * phi * (kappa - r - 1) + kappa + 2 * r + 2) / (phi * (1 - kappa + r) + kappa + 2 * r + 2))
    assert m.hasselman_johnson(phi, kappa, c) == pytest.approx(published, rel=1e-9)
    assert m.hasselman_johnson(phi, kappa, 0.0) == m.maxwell_eucken(phi, kappa)


@settings(max_examples=200, deadline=None)
@given(PHI, st.integers(105, 2**20))
def test_neutral_inclusion_gives_one(phi: float, j: int) -> None:
    """D + C = 1: a uniform field excites no multipole, E = 1 exactly (effective_formulas.md §4).

    D = j / 2^20 and C = 1 − D are exact binary fractions (κ = 1/D from 1 to 9986), so the inputs are
    neutral to the last bit (C = 1 − 1/κ rounded would add up to κ × 2.2e-16 to E − 1 by itself).  V3U
    is 1 + φ(κ − 1) minus a quotient of the same size, so its rounding floor is about φ κ ulps (measured
    up to 1.0 φ κ ulps, 9.1e-13 at φ κ = 4200); the tolerance is 4 ulps of the largest term, at least 1e-12.
    """
    d = j / 2**20
    kappa, c = 1.0 / d, 1.0 - d
    tol = max(1e-12, 4.0 * np.finfo(float).eps * (1.0 + phi * kappa))
    for f in WITH_CONTACT:
        assert f(phi, kappa, c) == pytest.approx(1.0, abs=tol)


@settings(max_examples=200, deadline=None)
@given(PHI, KAPPA, CONTACT)
def test_models_with_contact_decrease_with_resistance(phi: float, kappa: float, c: float) -> None:
    c2 = 1.5 * c + 1e-6
    for f in (m.hasselman_johnson, m.torquato_rintoul_lower, m.rayleigh_simple_cubic):
        assert f(phi, kappa, c2) <= f(phi, kappa, c) * (1 + RTOL)


def test_rayleigh_matches_the_exact_simple_cubic_value_with_contact() -> None:
    """effective_formulas.md §7: phi = 0.3, kappa = 10, C = 0.1, exact multipole value 1.6247400."""
    assert m.rayleigh_simple_cubic(0.3, 10.0, 0.1) == pytest.approx(1.6247400, abs=5e-6)


@pytest.mark.parametrize("phi", [0.05, 0.1, 0.2, 0.3])
@pytest.mark.parametrize("kappa", [1e-3, 0.1, 0.5, 2.0, 10.0, 100.0, 1e4])
@pytest.mark.parametrize("c", [0.0, 0.05, 0.2, 1.0, 5.0])
def test_third_order_bounds_bracket_the_exact_simple_cubic_value(phi: float, kappa: float, c: float) -> None:
    """With xi = zeta2(SC), V3L <= exact <= V3U (exact: Rayleigh's series, accurate to 1.3e-4 at phi = 0.3)."""
    exact = m.rayleigh_simple_cubic(phi, kappa, c)
    slack = 2e-4 if phi > 0.2 else 1e-5
    assert m.torquato_rintoul_lower(phi, kappa, c) <= exact * (1 + slack)
    assert exact <= m.torquato_rintoul_upper(phi, kappa, c) * (1 + slack)
    if c == 0.0:
        assert m.hashin_shtrikman_lower(phi, kappa) <= exact * (1 + slack)
        assert exact <= m.hashin_shtrikman_upper(phi, kappa) * (1 + slack)


def test_zeta2_reproduces_the_table_and_the_asymptote() -> None:
    phis = [0.05, 0.10, 4 * np.pi / 81, 0.20, 0.30, 0.40, 0.45, 0.50, 0.52]
    table = [4.0703e-5, 4.3387e-4, 2.0034e-3, 4.9474e-3, 0.022026, 0.067808, 0.110309, 0.173764, 0.206994]
    assert m.zeta2_simple_cubic(phis) == pytest.approx(table, rel=1e-12)
    small = np.array([1e-4, 1e-3, 1e-2])
    assert m.zeta2_simple_cubic(small) == pytest.approx(0.8388 * small ** (10 / 3) / (1 - small), rel=2e-3)
    grid = np.linspace(1e-4, PHI_MAX_SC, 500)
    assert np.all(np.diff(m.zeta2_simple_cubic(grid)) > 0)
    assert 0 < m.zeta2_simple_cubic(PHI_MAX_SC) < 0.25


@settings(max_examples=200, deadline=None)
@given(PHI, KAPPA)
def test_spheres_reduce_hatta_taya_and_lewis_nielsen_to_maxwell(phi: float, kappa: float) -> None:
    me = m.maxwell_eucken(phi, kappa)
    for orientation in ("random", "axial", "transverse"):
        assert m.hatta_taya(phi, kappa, 1.0, orientation) == pytest.approx(me, rel=1e-12)
    assert m.lewis_nielsen(phi, kappa, shape_factor=2.0, phi_max=1.0) == pytest.approx(me, rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(PHI, KAPPA)
def test_hatta_taya_needles_and_discs_reach_the_wiener_bounds(phi: float, kappa: float) -> None:
    assert m.hatta_taya(phi, kappa, 1e9, "axial") == pytest.approx(m.wiener_parallel(phi, kappa), rel=1e-6)
    assert m.hatta_taya(phi, kappa, 1e-12, "axial") == pytest.approx(m.wiener_series(phi, kappa), rel=1e-6)


@pytest.mark.parametrize("p", [1e-3, 0.3, 0.97, 0.9801, 0.9799, 0.995, 1 - 1e-9, 1.0, 1 + 1e-9, 1.005, 1.0199,
                               1.0201, 1.03, 3.0, 1e3])
def test_depolarization_factors_against_high_precision(p: float) -> None:
    mpmath.mp.dps = 50
    pm = mpmath.mpf(p)
    if pm > 1:
        q = mpmath.sqrt(pm**2 - 1)
        ref = pm / (2 * q**3) * (pm * q - mpmath.acosh(pm))
    elif pm < 1:
        q = mpmath.sqrt(1 - pm**2)
        ref = pm / (2 * q**3) * (mpmath.acos(pm) - pm * q)
    else:
        ref = mpmath.mpf(1) / 3
    s11, s33 = m.depolarization_factors(p)
    assert float(s11) == pytest.approx(float(ref), rel=1e-13, abs=1e-15)
    assert float(s11) * 2 + float(s33) == pytest.approx(1.0, rel=1e-15)


def test_cell_parameters_round_trip() -> None:
    b = np.array([0.0, 0.01, 0.5, 3.0])
    assert cell_B(cell_phi(b)) == pytest.approx(b, abs=1e-14)
    assert cell_phi(0.5) == pytest.approx(4 * np.pi / 81)


@pytest.mark.parametrize(("call", "word"), [
    (lambda: m.maxwell_eucken(0.0, 2.0), "phi"),
    (lambda: m.maxwell_eucken(1.2, 2.0), "phi"),
    (lambda: m.maxwell_eucken(0.2, 0.0), "kappa"),
    (lambda: m.maxwell_eucken(0.2, np.nan), "kappa"),
    (lambda: m.hasselman_johnson(0.2, 2.0, -1.0), "C"),
    (lambda: m.torquato_rintoul_lower(0.2, 2.0, 0.0, 1.5), "xi"),
    (lambda: m.rayleigh_simple_cubic(0.6, 2.0), "phi"),
    (lambda: m.lewis_nielsen(0.6, 2.0, phi_max=0.5), "phi_max"),
    (lambda: m.hatta_taya(0.2, 2.0, 1.0, "diagonal"), "orientation"),  # type: ignore[arg-type]
])
def test_bad_input_is_refused_with_the_name(call, word: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError, match=word):
        call()
