"""Choosing the finite volumes: ``[model] discretisation``, ``--discretisation``, ``k = 0``, and what is refused."""

from __future__ import annotations

import itertools
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.reduction.model_key import scene_physics_key
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import scene_from_dict


def _data(model: dict | None = None, k_matrix: float = 1.0, **extra: dict) -> dict:  # type: ignore[type-arg]
    data = {"geometry": {"generator": "sphere_in_cube", "n": 8, "voxel_size": 1e-3},
            "phases": {"matrix": {"label": 0, "k": k_matrix}, "inclusion": {"label": 1, "k": 10.0}}, **extra}
    return {**data, "model": model} if model is not None else data


def test_the_scene_chooses_fv_and_the_model_key_tells_the_two_apart() -> None:
    fv = scene_from_dict(_data({"discretisation": "fv"}))
    q1 = scene_from_dict(_data())
    assert (fv.discretisation, q1.discretisation) == ("fv", "q1")
    assert scene_physics_key(fv) != scene_physics_key(q1)


@pytest.mark.parametrize("image", ["sphere", "random"])
def test_the_two_discretisations_bracket_the_voxel_geometry_and_close_in_on_it(image: str) -> None:
    """Q1 is conforming: its energy is an upper bound of the voxel geometry's (k_Q1 ≥ k).  The two-point finite
    volumes are the lowest-order mixed elements with a lumped flux mass [Arbogast1997], which only adds
    complementary energy: k_FV ≤ k.  Splitting every voxel (the same geometry) moves both towards k."""
    scene = scene_from_dict(_data())
    if image == "random":
        labels = (np.random.default_rng(0).random((5, 5, 5)) < 0.4).astype(int)
        scene = replace(scene, geometry=VoxelGeometry(labels, (1e-3,) * 3))
    floor = 1e-8  # direct solves; far below the gaps measured (≥ 1e-2 relative)
    for boundary in ("periodic", "temperature"):
        fv = [effective_conductivity(replace(scene.refined(r), discretisation="fv"), boundary, "splu").k
              for r in (1, 2, 3)]
        q1 = [effective_conductivity(scene.refined(r), boundary, "splu").k for r in (1, 2, 3)]
        for lower, upper in itertools.pairwise(fv):
            assert np.linalg.eigvalsh(upper - lower).min() >= -floor  # rises with refinement
        for lower, upper in itertools.pairwise(q1):
            assert np.linalg.eigvalsh(lower - upper).min() >= -floor  # falls
        assert np.linalg.eigvalsh(q1[-1] - fv[-1]).min() > 0  # and they bracket


@pytest.mark.parametrize(("model", "k", "message"), [
    ({"discretisation": "fd"}, 1.0, r"model\.discretisation: unknown discretisation 'fd'; allowed: q1"),
    ({"discretisation": "fv", "solver": "x"}, 1.0, r"model.*solver"),
    (None, -1.0, r"phases\.matrix\.k: must be >= 0"),
])
def test_bad_model_sections_are_refused_naming_the_key(model: dict | None, k: float,  # type: ignore[type-arg]
                                                       message: str) -> None:
    with pytest.raises(InputError, match=message):
        scene_from_dict(_data(model, k))


def test_homogenize_command_takes_discretisation_and_an_insulating_phase(tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    labels = np.zeros((4, 4, 6), dtype=np.int32)
    labels[1:3, 1:3, :] = 1  # a straight pore along z through an insulating solid
    np.save(tmp_path / "pore.npy", labels)
    scene = tmp_path / "pore.toml"
    scene.write_text('[geometry]\nimage = "pore.npy"\nvoxel_size = 1e-6\n[phases.solid]\nlabel = 0\nk = 0.0\n'
                     '[phases.pore]\nlabel = 1\nk = 1.0\n', encoding="utf-8")
    assert main(["homogenize", str(scene), "--boundary", "temperature", "--json"]) == 2  # q1: the solid's nodes
    err = capsys.readouterr().err
    assert "touch no conducting voxel" in err and "--discretisation fv" in err
    assert main(["homogenize", str(scene), "--boundary", "temperature", "--discretisation", "fv", "--json"]) == 0
    k = np.array(json.loads(capsys.readouterr().out)["k"])
    np.testing.assert_allclose(np.diag(k), [0.0, 0.0, 0.25], rtol=1e-8, atol=1e-12)
