"""Reading an image by z-slabs (the petsc engine's input) gives the voxels the whole-image reader gives, and the
slab layout owns every node exactly once in the serial numbering of aromm.fem."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tifffile
from hypothesis import given
from hypothesis import strategies as st

from aromm.core.errors import InputError
from aromm.engines import check_engine, petsc_available
from aromm.engines.petsc.layout import SlabLayout, even_split
from aromm.fem.voxel import node_index
from aromm.microstructure import load_image
from aromm.microstructure.slabs import ImageSlabs
from aromm.scene.scene_file import scene_from_dict

SHAPE = (3, 4, 7)


def coded() -> np.ndarray:
    """Every voxel a different label: a slab read from the wrong place cannot match."""
    return np.arange(np.prod(SHAPE), dtype=np.int32).reshape(SHAPE) % 251


def write(kind: str, folder: Path, image: np.ndarray) -> tuple[Path, dict[str, object]]:
    if kind == "npy":
        np.save(folder / "img.npy", image.astype(np.uint8))
        return folder / "img.npy", {}
    if kind == "npz":
        np.savez_compressed(folder / "img.npz", labels=image)
        return folder / "img.npz", {}
    if kind == "tiff":
        tifffile.imwrite(folder / "img.tif", image.transpose(2, 1, 0).astype(np.uint8), photometric="minisblack")
        return folder / "img.tif", {}
    if kind == "rgb-like tiff":  # last axis of 3 stored as samples of one page: read whole
        tifffile.imwrite(folder / "img.tif", image.transpose(2, 1, 0).astype(np.uint8))
        return folder / "img.tif", {}
    if kind == "slices":
        for k in range(image.shape[2]):
            tifffile.imwrite(folder / f"s_{k + 1}.tif", image[:, :, k].T.astype(np.uint8).copy())
        return folder, {}
    image.astype(np.uint8).transpose(2, 1, 0).copy().tofile(folder / "img.raw")  # x fastest, z slowest
    return folder / "img.raw", {"shape": SHAPE}


@pytest.mark.parametrize("kind", ["npy", "npz", "tiff", "slices", "raw", "rgb-like tiff"])
def test_slabs_equal_the_whole_image(kind: str, tmp_path: Path) -> None:
    image = coded()
    path, options = write(kind, tmp_path, image)
    whole, _ = load_image(path, **options)  # type: ignore[arg-type]
    np.testing.assert_array_equal(whole, image)
    slabs = ImageSlabs.open(path, **options)  # type: ignore[arg-type]
    assert slabs.shape == SHAPE
    for k0, k1 in [(0, 7), (0, 1), (2, 5), (6, 7)]:
        part = slabs.read(k0, k1)
        assert part.dtype == np.int32
        np.testing.assert_array_equal(part, image[:, :, k0:k1])
    assert slabs.labels_present(2, 5) == {int(v) for v in np.unique(image[:, :, 2:5])}


def test_slab_outside_the_image_is_refused(tmp_path: Path) -> None:
    slabs = ImageSlabs.from_array(coded())
    with pytest.raises(InputError, match=r"z-slab \[5, 9\) outside the image's 7 layers"):
        slabs.read(5, 9)


@given(nx=st.integers(1, 4), ny=st.integers(1, 4), nz=st.integers(1, 9), size=st.integers(1, 6))
def test_slab_rows_partition_the_serial_numbering(nx: int, ny: int, nz: int, size: int) -> None:
    if nz < size:
        with pytest.raises(InputError, match="every rank needs at least one layer"):
            SlabLayout.split((nx, ny, nz), size, 0)
        return
    layouts = [SlabLayout.split((nx, ny, nz), size, r) for r in range(size)]
    owned = np.concatenate([np.arange(s.rows.lo, s.rows.hi) for s in layouts])
    np.testing.assert_array_equal(owned, np.arange((nx + 1) * (ny + 1) * (nz + 1)))  # each node once, in order
    for s in layouts:
        # the slab's first node is the global node (0, 0, k0), and its own rows are its node planes
        assert s.offset == node_index((nx, ny, nz), 0, 0, s.k0)
        assert s.rows.lo == s.offset
        assert s.k1 - s.k0 in (nz // size, nz // size + 1)
        assert ("z0" in s.faces()) == (s.k0 == 0) and ("z1" in s.faces()) == (s.k1 == nz)


def test_even_split_sizes_differ_by_at_most_one() -> None:
    assert even_split(10, 3) == (0, 4, 7, 10)
    assert even_split(2, 2) == (0, 1, 2)


def _scene_dict(labels: dict[str, int]) -> dict[str, object]:
    return {"geometry": {"image": "ignored.npy", "voxel_size": 1e-3},
            "phases": {name: {"label": label, "k": 1.0} for name, label in labels.items()}}


def test_scene_checks_phases_against_the_labels_found_by_slabs(tmp_path: Path) -> None:
    """The stand-in image holding each label present once gives the same phase checks as the whole image."""
    (tmp_path / "ignored.npy").write_bytes(b"")
    stand_in = np.array([0, 1], dtype=np.int32).reshape(-1, 1, 1)
    scene = scene_from_dict(_scene_dict({"gas": 0, "fibre": 1}), tmp_path / "s.toml", image=(stand_in, None))
    assert [ph.name for ph in scene.phases] == ["gas", "fibre"]
    with pytest.raises(InputError, match=r"image labels \[1\] belong to no phase"):
        scene_from_dict(_scene_dict({"gas": 0}), tmp_path / "s.toml", image=(stand_in, None))
    with pytest.raises(InputError, match="label 2 is absent from the image"):
        scene_from_dict(_scene_dict({"gas": 0, "fibre": 1, "resin": 2}), tmp_path / "s.toml",
                        image=(stand_in, None))


def test_importing_aromm_does_not_import_petsc() -> None:
    code = ("import sys, aromm, aromm.cli, aromm.engines, aromm.engines.petsc.layout, inverse.farm; "
            "print(sorted(m for m in ('petsc4py', 'slepc4py', 'mpi4py') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_unknown_engine_and_missing_petsc_are_input_errors() -> None:
    with pytest.raises(InputError, match="unknown engine 'cuda'; allowed: scipy, petsc"):
        check_engine("cuda")
    assert check_engine("scipy") == "scipy"
    if petsc_available():
        assert check_engine("petsc") == "petsc"
    else:
        with pytest.raises(InputError, match="apt-get install python3-petsc4py"):
            check_engine("petsc")
