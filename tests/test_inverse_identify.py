"""identify(): twin recovery on small full models, joint scenarios, a third unknown, checkpoints, JSON, refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from inverse_cases import TRUTH, scenario_model

from aromm.core.errors import InputError
from inverse.identification import Progress, identify
from inverse.measurements import simulate_measurements

UNKNOWNS = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}


def _rel(result_estimates: dict[str, float], truth: dict[str, float]) -> dict[str, float]:
    return {k: abs(result_estimates[k] - v) / v for k, v in truth.items()}


def test_twin_measurements_of_the_heterogeneous_model_are_recovered() -> None:
    """Data from the full model itself, no noise: k_F and c_F back to 0.1 % [Chavez2020, eq. 12 minimum is 0]."""
    model = scenario_model("z")
    y = simulate_measurements(model, TRUTH)
    res = identify(model, y, UNKNOWNS, seed=0, particles=10, iterations=10)
    errors = _rel(res.estimates, TRUTH)
    assert max(errors.values()) < 1e-3, errors
    assert res.criterion < 1e-12
    assert res.evaluations >= 10 * 11
    assert res.history.stage[0] == "pso" and res.history.stage[-1] == "refine"
    assert np.all(np.diff(res.history.criterion) <= 0)  # best-so-far never increases


def test_joint_identification_from_two_scenarios() -> None:
    pairs = [(m, simulate_measurements(m, TRUTH)) for m in (scenario_model("z"), scenario_model("x"))]
    res = identify(pairs, unknowns=UNKNOWNS, particles=10, iterations=8)
    assert max(_rel(res.estimates, TRUTH).values()) < 1e-3
    assert res.model["scenarios"] == 2
    assert [f.name for f in res.fits] == ["1", "2"]
    assert res.uncertainty.dof == sum(p[1].as_array().size for p in pairs) - 2


def test_gas_conductivity_as_a_third_unknown() -> None:
    truth = {**TRUTH, "gas.k": 0.025}
    model = scenario_model("z")
    y = simulate_measurements(model, truth)
    res = identify(model, y, {**UNKNOWNS, "gas.k": (0.005, 0.1)}, particles=12, iterations=10)
    assert max(_rel(res.estimates, truth).values()) < 1e-3, res.estimates
    assert res.uncertainty.correlation.shape == (3, 3)


def test_fixed_parameters_are_applied() -> None:
    """Data made with k_G = 0.05; fixing gas.k at 0.05 recovers the fibre truth, the scene's 0.025 does not."""
    model = scenario_model("z")
    y = simulate_measurements(model, {**TRUTH, "gas.k": 0.05})
    right = identify(model, y, UNKNOWNS, fixed={"gas.k": 0.05}, particles=8, iterations=6)
    wrong = identify(model, y, UNKNOWNS, particles=8, iterations=6)
    assert max(_rel(right.estimates, TRUTH).values()) < 1e-3
    assert max(_rel(wrong.estimates, TRUTH).values()) > 1e-2


def test_noisy_twin_truth_inside_the_95_percent_intervals() -> None:
    model = scenario_model("z")
    y = simulate_measurements(model, TRUTH, noise=0.02, rng=np.random.default_rng(11))
    res = identify(model, y, UNKNOWNS, particles=8, iterations=8)
    unc = res.uncertainty
    for i, name in enumerate(unc.names):
        assert unc.lower[i] <= TRUTH[name] <= unc.upper[i], (name, unc.lower[i], unc.upper[i])
    assert unc.residual_std == pytest.approx(0.02, rel=0.2)  # 80 residuals estimate the noise level


def test_checkpoint_resume_reproduces_the_uninterrupted_run(tmp_path: Path) -> None:
    model = scenario_model("z", n=4, end=20.0, dt=1.0)
    y = simulate_measurements(model, TRUTH, noise=0.02, rng=np.random.default_rng(0))
    full = identify(model, y, UNKNOWNS, seed=3, particles=6, iterations=6)

    ck = tmp_path / "run.npz"

    class Stop(Exception):
        pass

    def stop_at_3(p: Progress) -> None:
        if p.stage == "pso" and p.step == 3:
            raise Stop

    with pytest.raises(Stop):
        identify(model, y, UNKNOWNS, seed=3, particles=6, iterations=6, checkpoint=ck, progress=stop_at_3)
    assert ck.exists() and not list(tmp_path.glob(".*"))  # atomic writes leave no temporary file
    resumed = identify(model, y, UNKNOWNS, seed=3, particles=6, iterations=6, checkpoint=ck, resume=True)
    assert resumed.estimates == full.estimates
    assert resumed.evaluations == full.evaluations
    np.testing.assert_array_equal(resumed.history.criterion, full.history.criterion)
    with pytest.raises(InputError, match="another identification problem"):
        identify(model, y, UNKNOWNS, seed=4, particles=6, iterations=6, checkpoint=ck, resume=True)


def test_to_json_has_the_design_shape() -> None:
    model = scenario_model("z", n=4, end=20.0, dt=1.0)
    y = simulate_measurements(model, TRUTH, noise=0.02, rng=np.random.default_rng(0))
    res = identify(model, y, UNKNOWNS, particles=6, iterations=3, description={"kind": "full"})
    doc = json.loads(json.dumps(res.to_json()))
    assert list(doc) == ["estimates", "criterion", "evaluations", "seconds", "model", "uncertainty"]
    assert set(doc["estimates"]) == {"fibre.k", "fibre.c"}
    assert doc["model"]["kind"] == "full"
    assert set(doc["uncertainty"]["interval95"]) == {"fibre.k", "fibre.c"}
    assert -1.0 <= doc["uncertainty"]["correlation"]["fibre.k"]["fibre.c"] <= 1.0


def test_estimate_on_a_bound_is_reported() -> None:
    model = scenario_model("z", n=4, end=20.0, dt=1.0)
    y = simulate_measurements(model, TRUTH)
    with pytest.warns(UserWarning, match="fibre.k = 0.2 is at its upper bound"):
        res = identify(model, y, {"fibre.k": (0.05, 0.2), "fibre.c": (1e5, 1e7)}, particles=6, iterations=4)
    assert res.estimates["fibre.k"] == pytest.approx(0.2)


@pytest.mark.parametrize(("unknowns", "fixed", "message"), [
    ({"fibre.q": (0.0, 1.0)}, None, "unknown parameter 'fibre.q'"),
    (UNKNOWNS, {"fibre.k": 0.3}, "both unknown and fixed"),
    ({}, None, "no unknowns"),
    (None, None, "unknowns are required"),
])
def test_refusals(unknowns: dict | None, fixed: dict | None, message: str) -> None:
    model = scenario_model("z", n=3, end=4.0, dt=1.0)
    y = simulate_measurements(model, TRUTH)
    with pytest.raises(InputError, match=message):
        identify(model, y, unknowns, fixed=fixed, particles=4, iterations=1)


def test_measured_faces_must_be_model_outputs() -> None:
    z = scenario_model("z", n=3, end=4.0, dt=1.0)
    x = scenario_model("x", n=3, end=4.0, dt=1.0)
    with pytest.raises(InputError, match="allowed: z0, z1"):
        identify(z, simulate_measurements(x, TRUTH), UNKNOWNS, particles=4, iterations=1)
    with pytest.raises(InputError, match=r"expected a \(model, measurements\) pair"):
        identify([z], unknowns=UNKNOWNS)
