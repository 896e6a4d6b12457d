"""One cache key per reduced model whichever engine builds it (issue 21, item 5).

Independent truths: a digest that is a sum over voxels cannot depend on how the image is cut, so the sum of the
lanes of any cut equals the lanes of the whole image (checked on random cuts); changing one voxel or swapping
two must change it; the key must not move with the options that say *how* the model is computed (engine,
solvers) and must move with those that say *which* model (order, method, box).  The cross-engine checks (a
model built on petsc found on scipy and the other way round, within the engines' agreement) are in
tests/test_model_key_mpi.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scene_text import scenario_1

import aromm
from aromm.microstructure.digest import LANES, box_lanes, label_digest, lanes_hex
from aromm.reduction.model_key import model_key, physics_key, plain, scene_physics_key

BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1.0e6, 1.0e7)}


def _image(shape: tuple[int, int, int], seed: int) -> np.ndarray:
    return (np.random.default_rng(seed).random(shape) < 0.4).astype(np.int32)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 5), st.integers(1, 5), st.integers(1, 5), st.data())
def test_digest_of_any_cut_equals_the_whole(nx: int, ny: int, nz: int, data: st.DataObject) -> None:
    labels = _image((nx, ny, nz), data.draw(st.integers(0, 99)))
    cuts = [sorted({0, n, *data.draw(st.lists(st.integers(1, max(n - 1, 1)), max_size=2))}) for n in (nx, ny, nz)]
    total = np.zeros(LANES, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for x0, x1 in zip(cuts[0][:-1], cuts[0][1:], strict=True):
            for y0, y1 in zip(cuts[1][:-1], cuts[1][1:], strict=True):
                for z0, z1 in zip(cuts[2][:-1], cuts[2][1:], strict=True):
                    if x1 > x0 and y1 > y0 and z1 > z0:
                        total += box_lanes(labels[x0:x1, y0:y1, z0:z1], ((x0, x1), (y0, y1), (z0, z1)),
                                           labels.shape)
    assert lanes_hex(total) == label_digest(labels)


def test_digest_sees_one_voxel_and_a_swap() -> None:
    labels = _image((6, 5, 4), 1)
    base = label_digest(labels)
    changed = labels.copy()
    changed[2, 3, 1] = 1 - changed[2, 3, 1]
    assert label_digest(changed) != base
    swapped = labels.copy()
    a, b = (0, 0, 0), tuple(int(i[0]) for i in np.nonzero(labels != labels[0, 0, 0]))
    swapped[a], swapped[b] = labels[b], labels[a]
    assert label_digest(swapped) != base
    assert label_digest(labels.astype(np.uint8)) == base  # the labels, not their storage type


def test_physics_key_is_the_same_for_numpy_and_python_numbers() -> None:
    args = {"phases": "phases", "boundary": "faces", "initial_T": 0.0, "time": ("grid", 1.0), "outputs": ("z0",)}
    assert physics_key("d", shape=(2, 3, 4), voxel_size=(1e-4,) * 3, **args) == physics_key(
        "d", shape=np.array([2, 3, 4]), voxel_size=tuple(np.float64(1e-4) for _ in range(3)), **args)
    assert plain({"b": np.float64(2.0), "a": [np.int64(1)]}) == (("a", (1,)), ("b", 2.0))


def test_model_key_ignores_how_and_follows_which() -> None:
    base = {"method": "krylov", "bounds": BOX, "basis_values": {}, "reference_values": {}}
    key = model_key("p", 50, base)
    for how in ({"engine": "petsc"}, {"solver": "mumps"}, {"eigensolver": "lobpcg"}, {"cache": "/tmp/x"},
                {"progress": True}, {"basis_storage": "float32"}):
        assert model_key("p", 50, {**base, **how}) == key, how
    for which in ({"method": "aromm"}, {"bounds": {"fibre.k": (0.1, 2.0), "fibre.c": (1e6, 1e7)}},
                  {"basis_values": {"fibre.k": 0.5}}):
        assert model_key("p", 50, {**base, **which}) != key, which
    assert model_key("p", 40, base) != key and model_key("q", 50, base) != key
    assert model_key("p", 50, base, ["r"]) != key
    assert model_key("p", 50, {"method": "krylov", "bounds": BOX}) == key  # empty overrides = the defaults


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    np.save(tmp_path / "img.npy", _image((4, 5, 6), 3))
    path = tmp_path / "s.toml"
    path.write_text(scenario_1("img.npy", "1e-4", "2.0", "0.2"), encoding="utf-8")
    return path


def test_a_model_is_found_whatever_solver_built_it(scene: Path, tmp_path: Path) -> None:
    """Built with SuperLU, asked with CHOLMOD: the same model (the key names no solver), loaded not rebuilt."""
    loaded = aromm.load_scene(scene)
    assert scene_physics_key(loaded) is not None
    options = {"modes": 30, "cache": tmp_path / "cache"}
    built = aromm.reduce(loaded, 12, solver="splu", **options)
    assert built.info["cached"] == 0 and built.info["engine"] == "scipy"
    found = aromm.reduce(aromm.load_scene(scene), 12, solver="cholmod", **options)
    assert found.info["cached"] == 1 and found.info["model_key"] == built.info["model_key"]
    np.testing.assert_array_equal(found.simulate().as_array(), built.simulate().as_array())
    again = aromm.reduce(loaded, 10, **options)  # another order: another model
    assert again.info["cached"] == 0 and again.info["model_key"] != built.info["model_key"]


def test_an_assembled_system_keeps_the_engine_key(scene: Path, tmp_path: Path) -> None:
    rom = aromm.reduce(aromm.assemble(aromm.load_scene(scene)), 10, modes=20, cache=tmp_path / "cache")
    assert "model_key" not in rom.info
