"""The shipped pulse scene (data/scenes/wood_pulse.toml, the CLI's form) is the experiment of
aromm.studies.pulse_experiment
(the notebook's form)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aromm.scene.scene_file import load_scene
from aromm.scene.sensors import FaceSensor, PointSensor
from aromm.studies.pulse_experiment import PULSE, experiment

SCENES = Path(__file__).resolve().parents[1] / "data" / "scenes"


def test_shipped_pulse_scene_is_the_study_experiment() -> None:
    shipped = load_scene(SCENES / "wood_pulse.toml")
    built = experiment(load_scene(SCENES / "wood_s1.toml"))
    assert shipped.time == built.time and shipped.outputs == built.outputs == ()
    assert shipped.parameters == built.parameters and shipped.reduction == built.reduction
    z0 = {f.face: f for f in shipped.boundary}["z0"].flux
    assert np.array_equal(z0.times, PULSE.times) and np.array_equal(z0.values, PULSE.values)
    assert [s.name for s in shipped.sensors] == [s.name for s in built.sensors]
    for a, b in zip(shipped.sensors, built.sensors, strict=True):
        if isinstance(a, PointSensor):
            assert isinstance(b, PointSensor) and a.point == pytest.approx(b.point, rel=1e-12)
        else:
            assert isinstance(a, FaceSensor) and isinstance(b, FaceSensor) and a.face == b.face
            assert np.allclose(a.window, b.window, rtol=1e-12, atol=0)
