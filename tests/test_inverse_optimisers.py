"""PSO (pyswarms, contained) and local refinement on functions with known minima; side-effect containment."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aromm.core.errors import InputError
from inverse.optimisers import Box, jacobian, pso, refine

ROOT = Path(__file__).resolve().parents[1]


def test_box_maps_both_ways_and_logs_wide_positive_ranges() -> None:
    box = Box.from_bounds({"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7), "z1.T_ext": (-10.0, 10.0)})
    assert box.log == (False, True, False)  # 20x: linear; two decades: log; signed: linear
    u = np.array([[0.0, 0.5, 0.25], [1.0, 1.0, 1.0]])
    theta = box.to_physical(u)
    np.testing.assert_allclose(theta[0], [0.05, 1e6, -5.0])  # log midpoint of [1e5, 1e7] is 1e6
    np.testing.assert_allclose(theta[1], [1.0, 1e7, 10.0])
    np.testing.assert_allclose(box.to_unit(theta), u, atol=1e-14)
    h = 1e-7  # derivative of the map against a finite difference
    d = (box.to_physical(u + h) - box.to_physical(u - h)) / (2 * h)
    np.testing.assert_allclose(box.dtheta_du(u), d, rtol=1e-6)


@pytest.mark.parametrize("bounds", [{"a": (1.0, 1.0)}, {"a": (2.0, 1.0)}, {"a": (0.0, float("inf"))}, {"a": "x"}, {}])
def test_box_refuses_bad_bounds(bounds: dict) -> None:
    with pytest.raises(InputError):
        Box.from_bounds(bounds)


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(min_value=0.1, max_value=0.9), min_size=3, max_size=3), st.integers(0, 2**31))
def test_pso_finds_a_shifted_quadratic_minimum(centre: list[float], seed: int) -> None:
    """Interior minimum, 20 particles x 60 iterations: located to 2e-3 of the range (measured max 2.3e-4)."""
    c = np.array(centre)
    state = pso(lambda u: np.sum((u - c) ** 2, axis=1), 3, np.random.default_rng(seed), particles=20, iterations=60)
    np.testing.assert_allclose(state.best_pos, c, atol=2e-3)


def test_pso_finds_the_rosenbrock_valley_minimum_and_refinement_reaches_it() -> None:
    lo, span = np.array([-2.0, -1.0]), 4.0  # x in [-2, 2], y in [-1, 3]; minimum 0 at (1, 1)

    def residuals(u: np.ndarray) -> np.ndarray:
        x, y = (lo + span * u).T
        return np.column_stack([1.0 - x, 10.0 * (y - x**2)])

    state = pso(lambda u: np.sum(residuals(u) ** 2, axis=1), 2, np.random.default_rng(3), particles=30,
                iterations=100)
    assert state.best_cost < 1e-2
    np.testing.assert_allclose(lo + span * state.best_pos, [1.0, 1.0], atol=0.1)
    local = refine(residuals, state.best_pos)
    np.testing.assert_allclose(lo + span * local.u, [1.0, 1.0], atol=1e-8)
    assert local.cost < 1e-16


def test_pso_respects_bounds_when_the_minimum_is_outside() -> None:
    """Minimum beyond the corner (1, 1): particles stay inside (reflected, never wrapped round to 0)."""
    seen: list[np.ndarray] = []

    def residuals(u: np.ndarray) -> np.ndarray:
        seen.append(u.copy())
        return u - 1.7

    state = pso(lambda u: np.sum(residuals(u) ** 2, axis=1), 2, np.random.default_rng(0), particles=10,
                iterations=30)
    allu = np.vstack(seen)
    assert allu.min() >= 0.0 and allu.max() <= 1.0
    np.testing.assert_allclose(state.best_pos, [1.0, 1.0], atol=0.1)
    np.testing.assert_allclose(refine(residuals, state.best_pos).u, [1.0, 1.0], atol=1e-12)


def test_pso_is_reproducible_and_resumes_exactly() -> None:
    f = lambda u: np.sum((u - 0.3) ** 2, axis=1) + 0.1 * np.sin(20 * u[:, 0])  # noqa: E731
    a = pso(f, 2, np.random.default_rng(7), particles=8, iterations=12)
    b = pso(f, 2, np.random.default_rng(7), particles=8, iterations=12)
    np.testing.assert_array_equal(a.position, b.position)
    half = pso(f, 2, np.random.default_rng(7), particles=8, iterations=5)
    # continue from the saved arrays (as a checkpoint does) with a fresh, differently seeded generator
    from inverse.optimisers import SwarmState

    resumed = pso(f, 2, np.random.default_rng(999), iterations=12, state=SwarmState.from_arrays(half.to_arrays()))
    np.testing.assert_array_equal(resumed.position, a.position)
    np.testing.assert_array_equal(resumed.pbest_cost, a.pbest_cost)
    c = pso(f, 2, np.random.default_rng(8), particles=8, iterations=12)
    assert not np.array_equal(c.position, a.position)


def test_jacobian_is_exact_on_a_linear_map_and_one_sided_at_bounds() -> None:
    a = np.array([[1.0, 2.0], [3.0, -1.0], [0.5, 0.0]])

    def r(u: np.ndarray) -> np.ndarray:
        return u @ a.T

    for u in ([0.5, 0.5], [0.0, 1.0]):
        np.testing.assert_allclose(jacobian(r, np.array(u)), a, rtol=1e-9)


def test_a_run_leaves_no_file_no_logging_change_and_no_global_rng_change(tmp_path: Path) -> None:
    """In a fresh interpreter (pyswarms not yet imported) inside an empty directory."""
    script = textwrap.dedent("""
        import json, logging, os, sys
        import numpy as np
        root = logging.getLogger()
        before = (root.level, [type(h).__name__ for h in root.handlers])
        np.random.seed(11)
        draw_ref = np.random.RandomState(11).random_sample(3).tolist()
        env_before = os.environ.get("LOG_CFG")
        from inverse.optimisers import pso
        s1 = pso(lambda u: np.sum((u - 0.4) ** 2, axis=1), 2, np.random.default_rng(1), particles=6, iterations=4)
        s2 = pso(lambda u: np.sum((u - 0.4) ** 2, axis=1), 2, np.random.default_rng(1), particles=6, iterations=4)
        import pyswarms  # importing it again is a no-op; check nothing slipped through
        after = (root.level, [type(h).__name__ for h in root.handlers])
        print(json.dumps({
            "files": sorted(os.listdir(".")),
            "logging_same": before == after,
            "handlers": after[1],
            "global_rng_untouched": np.random.random_sample(3).tolist() == draw_ref,
            "env_same": os.environ.get("LOG_CFG") == env_before,
            "reproducible": s1.position.tolist() == s2.position.tolist(),
        }))
    """)
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("LOG_CFG", None)
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True,
                         check=True, timeout=120)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report == {"files": [], "logging_same": True, "handlers": [], "global_rng_untouched": True,
                      "env_same": True, "reproducible": True}
    assert "report.log" not in out.stderr and "INFO" not in out.stderr


def test_differential_evolution_then_refinement_is_a_drop_in_chain() -> None:
    """Another global search in the identification chain (inverse.optimisers is pluggable): the Rosenbrock
    minimum (1, 1) is found by differential evolution + least squares, reproducibly from one seed."""
    from inverse.optimisers import DifferentialEvolution, LeastSquaresRefinement, Problem

    lo, span = np.array([-2.0, -1.0]), 4.0

    def residuals(u: np.ndarray) -> np.ndarray:
        x, y = (lo + span * np.atleast_2d(u)).T
        return np.column_stack([1.0 - x, 10.0 * (y - x**2)])

    problem = Problem(2, residuals)
    runs = []
    for _ in range(2):
        rng = np.random.default_rng(5)
        coarse = DifferentialEvolution(population=15, generations=40).run(problem, None, rng)
        runs.append(LeastSquaresRefinement().run(problem, coarse.u, rng))
    np.testing.assert_allclose(lo + span * runs[0].u, [1.0, 1.0], atol=1e-8)
    np.testing.assert_array_equal(runs[0].u, runs[1].u)


def test_identify_accepts_an_optimiser_chain_and_refuses_what_is_not_one() -> None:
    from inverse_cases import LinearModel

    from inverse import Measurements, identify
    from inverse.optimisers import DifferentialEvolution, LeastSquaresRefinement

    t = np.arange(1.0, 9.0)
    model = LinearModel(np.column_stack([np.ones_like(t), t]), ("a", "b"))  # y = a + b t
    data = Measurements(model.default_times, {"a": 2.0 - t})
    result = identify(model, data, {"a": (-10.0, 10.0), "b": (-5.0, 5.0)},
                      optimisers=[DifferentialEvolution(generations=20), LeastSquaresRefinement()])
    assert result.estimates == pytest.approx({"a": 2.0, "b": -1.0}, abs=1e-8)
    assert set(result.history.stage) == {"differential-evolution", "refine"}
    with pytest.raises(InputError, match="not an optimiser"):
        identify(model, data, {"a": (-10.0, 10.0)}, optimisers=["pso"])  # type: ignore[list-item]
