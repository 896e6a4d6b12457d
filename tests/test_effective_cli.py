"""``aromm bounds``: JSON contract of docs/design.md, exit codes, consistency with the library."""

from __future__ import annotations

import json

import numpy as np
import pytest

from aromm.bounds import models as m
from aromm.bounds.summary import MODEL_KEYS
from aromm.bounds.wall import wall_inf_a, wall_inf_b
from aromm.cli import main

DESIGN_KEYS = {"maxwell_eucken", "hasselman_johnson", "hashin_shtrikman_lower", "hashin_shtrikman_upper",
               "wiener_parallel", "wiener_series", "torquato_rintoul_lower", "torquato_rintoul_upper", "wall_1a",
               "wall_inf_a", "wall_1b", "wall_inf_b", "lewis_nielsen", "hatta_taya"}


def run_json(capsys: pytest.CaptureFixture[str], *args: str) -> dict[str, float | None]:
    code = main(["bounds", *args, "--json"])
    out = capsys.readouterr().out
    assert code == 0
    return json.loads(out)  # type: ignore[no-any-return]


def test_json_has_exactly_the_design_keys_and_bounds_are_ordered(capsys: pytest.CaptureFixture[str]) -> None:
    phi, kappa, c = 0.2, 10.0, 0.1
    values = run_json(capsys, "--phi", str(phi), "--ratio", str(kappa), "--contact", str(c), "--mesh-size", "0.5")
    assert set(values) == DESIGN_KEYS == set(MODEL_KEYS)
    assert values["hasselman_johnson"] == pytest.approx(m.hasselman_johnson(phi, kappa, c), rel=1e-15)
    b = (np.pi / (6 * phi)) ** (1 / 3) - 1  # B from phi for the simple-cubic cell
    assert values["wall_inf_a"] == pytest.approx(float(wall_inf_a(b, c, 1 / kappa)), rel=1e-13)
    exact = m.rayleigh_simple_cubic(phi, kappa, c)  # accurate to 2e-6 at phi = 0.2
    lower = [values[k] for k in ("wall_inf_a", "wall_1a", "torquato_rintoul_lower")]
    upper = [values[k] for k in ("wall_1b", "wall_inf_b", "torquato_rintoul_upper")]
    assert all(v is not None and v <= exact for v in lower)
    assert all(v is not None and v >= exact for v in upper)


def test_explicit_b_and_xi_are_used(capsys: pytest.CaptureFixture[str]) -> None:
    values = run_json(capsys, "--phi", "0.2", "--ratio", "5", "--contact", "0.3", "--B", "0.0", "--xi", "0.0")
    assert values["wall_1a"] is None and values["wall_1b"] is None  # touching spheres: no cell mesh
    assert values["wall_inf_b"] == pytest.approx(float(wall_inf_b(0.0, 0.3, 0.2)), rel=1e-12)
    # xi = 0 turns the upper third-order bound into Hasselman-Johnson (effective_formulas.md §9)
    assert values["torquato_rintoul_upper"] == pytest.approx(values["hasselman_johnson"], rel=1e-12)


@pytest.mark.parametrize(("args", "option"), [
    (["--phi", "0.6", "--ratio", "10"], "--phi"),
    (["--phi", "0", "--ratio", "10"], "--phi"),
    (["--phi", "0.2", "--ratio", "0"], "--ratio"),
    (["--phi", "0.2", "--ratio", "2", "--contact", "-0.1"], "--contact"),
    (["--phi", "0.2", "--ratio", "2", "--B", "-1"], "--B"),
    (["--phi", "0.2", "--ratio", "2", "--xi", "1.5"], "--xi"),
])
def test_bad_input_exits_2_naming_the_option(capsys: pytest.CaptureFixture[str], args: list[str],
                                             option: str) -> None:
    assert main(["bounds", *args]) == 2
    err = capsys.readouterr().err
    assert option in err and ("in (" in err or "in [" in err)


def test_table_lists_every_model(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bounds", "--phi", "0.1", "--ratio", "0.1", "--mesh-size", "0.5"]) == 0
    out = capsys.readouterr().out
    for key in MODEL_KEYS:
        assert key in out
