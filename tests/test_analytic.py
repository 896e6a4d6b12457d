"""The slab series of [Hassan2019, eq. 12-13]: boundary values, initial state, heat equation, steady limit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aromm.core.errors import InputError
from aromm.full.analytic import slab_dirichlet_series

L, ALPHA = 0.1, 33.0 / (7800 * 0.9)


def test_boundaries_and_steady_limit() -> None:
    x = np.linspace(0, L, 11)
    t_walls = slab_dirichlet_series(np.array([0.0, L]), 0.05, L, ALPHA, 25.0, 25.0, 100.0)
    np.testing.assert_allclose(t_walls, [25.0, 100.0], atol=1e-9)
    late = slab_dirichlet_series(x, 1e3, L, ALPHA, 25.0, 25.0, 100.0)
    np.testing.assert_allclose(late, 25.0 + 75.0 * x / L, atol=1e-9)


def test_initial_state_recovered_inside() -> None:
    x = np.linspace(0.2 * L, 0.8 * L, 7)  # away from the walls (Gibbs)
    t0 = slab_dirichlet_series(x, 0.0, L, ALPHA, 40.0, 25.0, 100.0, n_terms=20000)
    np.testing.assert_allclose(t0, 40.0, atol=0.05)


def test_satisfies_heat_equation() -> None:
    x, t, h, dt = 0.037, 0.08, 1e-4, 1e-5
    f = lambda xx, tt: slab_dirichlet_series(xx, tt, L, ALPHA, 25.0, 25.0, 100.0)  # noqa: E731
    dtdt = (f(x, t + dt) - f(x, t - dt)) / (2 * dt)
    d2 = (f(x + h, t) - 2 * f(x, t) + f(x - h, t)) / h**2
    assert dtdt == pytest.approx(ALPHA * d2, rel=1e-4)


def test_energy_balance_semi_infinite_early_time() -> None:
    """Early on the hot wall sees a semi-infinite body: T = T0 + dT erfc(s / (2 sqrt(alpha t)))."""
    from scipy.special import erfc

    t = 0.005
    s = np.linspace(0, 0.01, 6)
    series = slab_dirichlet_series(L - s, t, L, ALPHA, 25.0, 25.0, 100.0)
    np.testing.assert_allclose(series, 25.0 + 75.0 * erfc(s / (2 * np.sqrt(ALPHA * t))), atol=1e-6)


@settings(max_examples=30, deadline=None)
@given(st.floats(-50, 50), st.floats(-50, 50), st.floats(-50, 50), st.floats(0.0, 1.0))
def test_linear_in_temperatures(t0: float, t1: float, t2: float, s: float) -> None:
    """Superposition: the field is affine in (T0, T_left, T_right), so shifting all three shifts T."""
    a = slab_dirichlet_series(s * L, 0.03, L, ALPHA, t0, t1, t2)
    b = slab_dirichlet_series(s * L, 0.03, L, ALPHA, t0 + 7.0, t1 + 7.0, t2 + 7.0)
    assert b == pytest.approx(a + 7.0, abs=1e-9)


def test_broadcast_and_refusals() -> None:
    out = slab_dirichlet_series(np.linspace(0, L, 5)[None, :], np.array([0.05, 0.1, 0.2])[:, None],
                                L, ALPHA, 25.0, 25.0, 100.0)
    assert out.shape == (3, 5)
    with pytest.raises(InputError, match="positive"):
        slab_dirichlet_series(0.0, 0.1, -1.0, ALPHA, 0, 0, 1)
    with pytest.raises(InputError, match="non-negative"):
        slab_dirichlet_series(0.0, -0.1, L, ALPHA, 0, 0, 1)
