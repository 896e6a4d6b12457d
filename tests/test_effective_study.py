"""Table 1 machinery and the preference map of [GarnierDanes]."""

from __future__ import annotations

import numpy as np
import pytest

from aromm.studies.garnier_danes import (
    LOWER,
    SEED_PREFERENCE,
    UPPER,
    Grid,
    deviation_table,
    evaluate_grid,
    ordering_violations,
    preference_boundary,
    preference_map,
)


def test_touching_limit_of_the_preference_map_reproduces_the_seed_thresholds() -> None:
    """[GarnierDanes]: W_inf_a beats V3L only for C < 0.1081 and D < 0.0496; with the seed's formulas and
    xi = zeta2(SC) these are the edges of that region for touching spheres (B -> 0)."""
    edge = preference_boundary(0.0)
    assert edge.d_star == pytest.approx(SEED_PREFERENCE["D"], rel=2e-3)
    assert edge.c_star == pytest.approx(SEED_PREFERENCE["C"], rel=5e-3)
    # the region shrinks as the spheres separate, and is gone by B = 0.05
    assert preference_boundary(0.01).d_star < edge.d_star
    assert np.isnan(preference_boundary(0.05).d_star)


def test_preference_map_sign_at_neutral_inclusion_and_dilute_cells() -> None:
    assert preference_map(0.3, 0.5, 0.5) == pytest.approx(0.0, abs=1e-12)  # both bounds are exactly 1
    assert preference_map(2.0, 0.1, 0.1) > 0  # dilute: V3L is the tighter


def test_grid_deviations_have_the_sign_of_the_bounds() -> None:
    """On a very coarse mesh (h = 0.5 a, P2: E_c within ~0.2 %) the bounds sit on their side of E_c,
    up to violations smaller than the change of E_c under refinement."""
    points = evaluate_grid(Grid(B=(0.5,), C=(0.0, 0.3), D=(0.05, 0.5), h=0.5))
    table = deviation_table(points)
    assert all(table[name][2] <= 0.3 for name in LOWER)  # max eps of the lower bounds
    assert all(table[name][1] >= -0.3 for name in UPPER)  # min eps of the upper bounds
    assert table["W_inf_a"][1] < -10 and table["W_inf_b"][2] > 30  # the wall bounds are not tight here
    assert all(abs(e) < p.mesh_change for p, _, e in ordering_violations(points))
