"""Intervals that respect a positive parameter's domain, a stated model error that widens them, and a results table
whose columns never run together (issue 23 item 3).  Truths: first-order agreement with the linear interval, the
exact least-squares shift of a proportional model, and the cells of the table read back."""

from __future__ import annotations

import re

import numpy as np
import pytest

from aromm.cli.identify_report import aligned
from inverse.uncertainty import domain_interval, linearised, model_error_std


def test_log_interval_stays_positive_and_matches_the_linear_one_to_first_order() -> None:
    beta = np.full(3, 2.0)
    half = np.array([1e-4, 0.5, 400.0])
    lo, hi = domain_interval(beta, half, np.ones(3, dtype=bool))
    assert np.all(lo > 0) and np.all(hi > beta)
    # β e^{±h/β} = β ± h + h²/(2β) + O(h³): the difference from the linear interval is second order
    assert abs(lo[0] - (2.0 - 1e-4)) < 1e-8 and abs(hi[0] - (2.0 + 1e-4)) < 1e-8
    np.testing.assert_allclose(np.log(hi) - np.log(beta), np.log(beta) - np.log(lo))  # symmetric in log β


def test_a_proportional_model_with_a_relative_model_error_shifts_the_estimate_by_that_fraction() -> None:
    """y = β x: a model error ε·ŷ is the same as a change ε β of the parameter, exactly."""
    x = np.linspace(1.0, 5.0, 12)[:, None]
    beta = 0.3
    assert model_error_std(x, 0.02, beta * x[:, 0])[0] == pytest.approx(0.02 * beta, rel=1e-12)


def test_the_model_error_widens_the_interval_and_is_listed_as_a_source() -> None:
    rng = np.random.default_rng(3)
    x = np.linspace(1.0, 5.0, 40)[:, None]
    r = 0.01 * rng.standard_normal(40)
    plain = linearised(["fibre.k"], np.array([0.3]), x, r, positive=[True])
    wide = linearised(["fibre.k"], np.array([0.3]), x, r, positive=[True], model_error=0.02, model_rise=0.3 * x[:, 0])
    assert wide.lower[0] < plain.lower[0] and wide.upper[0] > plain.upper[0]
    assert wide.std_error[0] == pytest.approx(np.hypot(plain.std_error[0], 0.02 * 0.3), rel=1e-12)
    assert any("model error of 0.02" in s for s in wide.error_sources)
    assert not any("model error" in s for s in plain.error_sources)
    assert wide.to_json()["interval_scale"] == {"fibre.k": "log"}


def test_table_columns_never_run_together() -> None:
    rows = [["parameter", "estimate", "std error", "rel. se"], ["fibre.k", "0.739", "10.9", "1.48e+03 %"],
            ["a.very.long.name", "-1.23456e+300", "inf", "-"]]
    for line, row in zip(aligned(rows, right=3), rows, strict=True):
        assert re.split(r"\s{2,}", line.strip()) == row
