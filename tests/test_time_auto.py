"""``[time] end = "auto"`` (aromm.scene.time_section): the grid it derives reaches the steady state it promises.

The rule claims that by ``end = 3 (t_D + τ_h)`` the body is 95 % of the way to its steady state, that ``dt`` leaves at
least ten outputs within the diffusion time and a hundred in all.  Checked against the steady state of the same
scene, which is known in closed form here: a fixed face drives every point to its temperature; a flux ``q`` in on one
face and an exchange ``h`` on the other settle at ``T_ext + q/h`` on the exchange face.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from aromm.api import simulate
from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.scene.scene_file import Scene, assemble, scene_from_dict
from aromm.scene.time_section import AUTO_PER_DIFFUSION, AUTO_STEPS, time_scales

SIZE = 1e-3  # m per voxel

CASES = {
    "fixed face": ({"z0": {"T": 10.0}}, "z1", 10.0),
    "flux and a strong exchange": ({"z0": {"flux": 100.0}, "z1": {"h": 1e3, "T_ext": 0.0}}, "z1", 0.1),
    "flux and a weak exchange (small Biot)": ({"z0": {"flux": 100.0}, "z1": {"h": 5.0, "T_ext": 0.0}}, "z1", 20.0),
}


def _scene(tmp_path: Path, boundary: dict, time: dict) -> Scene:  # type: ignore[type-arg]
    labels = np.zeros((3, 3, 8), dtype=np.int32)
    labels[:, :, 2::3] = 1  # layers across z
    np.save(tmp_path / "layers.npy", labels)
    return scene_from_dict({
        "geometry": {"image": "layers.npy", "voxel_size": SIZE},
        "phases": {"matrix": {"label": 0, "k": 0.2, "c": 1.0e6}, "layer": {"label": 1, "k": 5.0, "c": 3.0e6}},
        "boundary": boundary, "initial": {"T": 0.0}, "time": time, "outputs": {"mean_T": ["z0", "z1"]}},
        path=tmp_path / "scene.toml")


@pytest.mark.parametrize("case", CASES)
def test_the_automatic_end_is_ninety_five_percent_of_the_way_to_steady_state(tmp_path: Path, case: str) -> None:
    boundary, face, steady = CASES[case]
    scene = _scene(tmp_path, boundary, {"end": "auto", "dt": "auto"})
    grid = scene.time
    assert grid is not None
    (fast, slow), tau, _ = time_scales(scene.volume_fractions(), scene.phases, scene.boundary, scene.size)
    assert grid.end == pytest.approx(3 * (slow + tau), rel=0.05)  # dt rounded to two digits, end to whole steps
    assert round(grid.end / grid.dt) >= AUTO_STEPS and fast / grid.dt >= AUTO_PER_DIFFUSION * 0.95
    last = simulate(assemble(scene)).mean_T[face][-1]
    assert abs(last - steady) <= 0.05 * steady, (case, last, steady)


def test_the_diffusion_times_use_the_exact_mean_capacity_and_the_laminates_bounds(tmp_path: Path) -> None:
    """Across the layers the series Wiener bound is the laminate's exact k_zz and the parallel one its k_xx
    (two layers of eight slices); this scene is the laminate across z, the worst case of the rule."""
    scene = _scene(tmp_path, {"z0": {"T": 1.0}}, {"end": "auto"})
    phi = 2 / 8
    c_bar = phi * 3.0e6 + (1 - phi) * 1.0e6
    k_series, k_parallel = 1 / (phi / 5.0 + (1 - phi) / 0.2), phi * 5.0 + (1 - phi) * 0.2
    (fast, slow), tau, why = time_scales(scene.volume_fractions(), scene.phases, scene.boundary, scene.size)
    length = 8 * SIZE
    assert tau == 0.0 and "along z" in why
    assert fast == pytest.approx(c_bar * length**2 / k_parallel, rel=1e-12)
    assert slow == pytest.approx(c_bar * length**2 / k_series, rel=1e-12)


def test_an_insulating_phase_is_for_steady_scenes(tmp_path: Path) -> None:
    """A transient needs every phase to conduct: an insulating phase is refused with [time], "auto" or not, before
    the grid is worked out (its k_⊥ = 0 would have no end)."""
    labels = np.zeros((3, 3, 4), dtype=np.int32)
    labels[0] = 1
    np.save(tmp_path / "pores.npy", labels)
    data = {"geometry": {"image": "pores.npy", "voxel_size": SIZE},
            "phases": {"solid": {"label": 0, "k": 1.0, "c": 1e6}, "pore": {"label": 1, "k": 0.0, "c": 1e3}},
            "boundary": {"z0": {"T": 1.0}}, "time": {"end": "auto"}, "outputs": {"mean_T": ["z1"]},
            "model": {"discretisation": "fv"}}
    for time in ({"end": "auto"}, {"end": 10.0, "dt": "auto"}):
        with pytest.raises(InputError, match=r"phases\.pore\.k: k = 0 \(an insulating phase\) is for steady scenes"):
            scene_from_dict({**data, "time": time}, path=tmp_path / "scene.toml")


def test_a_given_end_keeps_its_value_and_gets_whole_steps(tmp_path: Path) -> None:
    scene = _scene(tmp_path, {"z0": {"T": 1.0}}, {"end": 7.3, "dt": "auto"})
    assert scene.time is not None and scene.time.end == 7.3
    assert scene.time.times[-1] == pytest.approx(7.3, rel=1e-12)


@pytest.mark.parametrize(("time", "message"), [
    ({"end": "often", "dt": 1.0}, 'time.end: must be a number of seconds or "auto"'),
    ({"end": 10.0}, 'needs dt (s, or "auto"'),
    ({"dt": 1.0}, 'needs end (s, or "auto"'),
])
def test_bad_time_values_are_refused_by_key(tmp_path: Path, time: dict, message: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(InputError, match=re.escape(message)):
        _scene(tmp_path, {"z0": {"T": 1.0}}, time)


def test_the_cli_shows_the_rule_and_its_numbers(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """On a terminal or in a log, the automatic grid is always said (aromm.cli.logs.NOTES)."""
    _scene(tmp_path, {"z0": {"T": 1.0}}, {"end": "auto"})  # writes layers.npy
    (tmp_path / "scene.toml").write_text(
        '[geometry]\nimage = "layers.npy"\nvoxel_size = 1e-3\n[phases.matrix]\nlabel = 0\nk = 0.2\nc = 1e6\n'
        '[phases.layer]\nlabel = 1\nk = 5.0\nc = 3e6\n[boundary.z0]\nT = 1.0\n[time]\nend = "auto"\n'
        '[outputs]\nmean_T = ["z1"]\n', encoding="utf-8")
    assert main(["simulate", str(tmp_path / "scene.toml")]) == 0
    err = capsys.readouterr().err
    assert "[time] auto: end = " in err and "t_D = c̄ L²/k" in err, err


def test_an_anisotropic_phase_enters_by_its_smallest_and_largest_principal_values() -> None:
    """The component of a tensor along any axis lies between its principal values: the lower Wiener bound takes the
    smallest, the upper one the largest, so the grid holds whatever the tensor's axes."""
    from aromm.core.anisotropy import PhaseTensor
    from aromm.scene.time_section import time_scales

    fibre = PhaseSpec("fibre", 0, 4.0, 1e6, tensor=PhaseTensor("fibre", (4.0, 1.0), ((1.0, 0.0, 0.0),)))
    (fast, slow), _, _ = time_scales({"fibre": 1.0}, (fibre,), (FaceSpec("z0", T=1.0),), (1.0, 1.0, 1.0))
    assert (fast, slow) == (1e6 / 4.0, 1e6 / 1.0)
