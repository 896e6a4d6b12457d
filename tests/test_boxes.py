"""Reading an image by boxes (the petsc engine's input) gives the voxels the whole-image reader gives while holding
only the box, and the box layout owns every node exactly once, in contiguous row blocks."""

from __future__ import annotations

import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import tifffile
from hypothesis import given
from hypothesis import strategies as st

from aromm.core.errors import InputError
from aromm.engines import check_engine, petsc_available
from aromm.engines.petsc.layout import BoxLayout, even_split, process_grid
from aromm.fem.voxel_grid import node_index
from aromm.microstructure import load_image
from aromm.microstructure.boxes import ImageBoxes, readable_by_parts
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


KINDS = ["npy", "npz", "tiff", "slices", "raw", "rgb-like tiff"]
BOXES = [((0, 3), (0, 4), (0, 7)), ((0, 1), (1, 3), (2, 5)), ((2, 3), (3, 4), (6, 7))]


@pytest.mark.parametrize("kind", KINDS)
def test_boxes_equal_the_whole_image(kind: str, tmp_path: Path) -> None:
    image = coded()
    path, options = write(kind, tmp_path, image)
    whole, _ = load_image(path, **options)  # type: ignore[arg-type]
    np.testing.assert_array_equal(whole, image)
    boxes = ImageBoxes.open(path, **options)  # type: ignore[arg-type]
    assert boxes.shape == SHAPE
    assert readable_by_parts(path, options.get("shape")) == (kind not in ("npz", "rgb-like tiff"))  # type: ignore[arg-type]
    for box in BOXES:
        part = boxes.read(box)
        assert part.dtype == np.int32
        np.testing.assert_array_equal(part, image[tuple(slice(*r) for r in box)])
    assert boxes.labels_present(BOXES[1]) == {int(v) for v in np.unique(image[0:1, 1:3, 2:5])}


def test_box_outside_the_image_is_refused() -> None:
    boxes = ImageBoxes.from_array(coded())
    with pytest.raises(InputError, match=r"box z range \[5, 9\) outside the image's 7 voxels"):
        boxes.read(((0, 3), (0, 4), (5, 9)))


@pytest.mark.parametrize("kind", ["npy", "raw", "tiff", "slices"])
def test_each_rank_reader_holds_only_its_box(kind: str, tmp_path: Path) -> None:
    """The bytes a rank's reader allocates (tracemalloc: numpy's buffers; a memory map's pages are the operating
    system's cache, not the process's) are its box as the file's dtype and as int32, plus one TIFF page and
    tifffile's objects of each page read (≈ 2 kB each, left to the garbage collector), for the four boxes of a
    2×2×1 cut of a 64×60×16 image; beyond those pages' transient objects, under half of what reading the whole image
    allocates (with them a box of the slices came within 1 % of half once: the collector's timing)."""
    shape = (64, 60, 16)
    image = (np.arange(np.prod(shape)).reshape(shape) % 7).astype(np.int32)
    path, options = write(kind, tmp_path, image) if kind != "raw" else _raw(tmp_path, image)
    tracemalloc.start()
    whole = load_image(path, **options)[0]  # type: ignore[arg-type]
    whole_bytes = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    del whole
    boxes = ImageBoxes.open(path, **options)  # type: ignore[arg-type]
    page = shape[0] * shape[1]  # uint8 pages
    for rank in range(4):
        layout = BoxLayout.split(shape, 4, rank, (2, 2, 1))
        voxels = int(np.prod(layout.box_shape))
        tracemalloc.start()
        part = boxes.read(layout.box)
        held = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert part.shape == layout.box_shape == (32, 30, 16)
        pages = (page + 2560) * shape[2] if kind in ("tiff", "slices") else 0
        assert voxels * 4 <= held <= voxels * (1 + 4) + pages + 4096, (rank, held)
        assert held - pages < 0.5 * whole_bytes, (held, pages, whole_bytes)
        print(f"{kind} rank {rank}: box {layout.box_shape} holds {held} B; the whole image {whole_bytes} B")


def _raw(folder: Path, image: np.ndarray) -> tuple[Path, dict[str, object]]:
    image.astype(np.uint8).transpose(2, 1, 0).copy().tofile(folder / "img.raw")
    return folder / "img.raw", {"shape": image.shape}


@given(nx=st.integers(1, 5), ny=st.integers(1, 5), nz=st.integers(1, 6), size=st.integers(1, 8))
def test_box_rows_partition_the_nodes(nx: int, ny: int, nz: int, size: int) -> None:
    """Every node has one owner and one row; each rank's rows are a contiguous block holding exactly the nodes it
    owns; every box's node rows (its own and its upper neighbours') are those the whole grid gives them."""
    shape = (nx, ny, nz)
    fits = any(m <= nx and n <= ny and size // (m * n) <= nz and size % (m * n) == 0
               for m in range(1, size + 1) for n in range(1, size + 1))
    if not fits:
        with pytest.raises(InputError, match="cannot be cut into"):
            process_grid(shape, size)
        return
    layouts = [BoxLayout.split(shape, size, r) for r in range(size)]
    rows, owner = layouts[0].global_rows((0, 0, 0), shape)
    np.testing.assert_array_equal(np.sort(rows), np.arange((nx + 1) * (ny + 1) * (nz + 1)))
    starts = layouts[0].rows.starts
    assert all(s.rows.starts == starts for s in layouts)
    np.testing.assert_array_equal(owner, np.searchsorted(starts, rows, side="right") - 1)
    for s in layouts:
        (x0, x1), (y0, y1), (z0, z1) = s.box
        assert min(x1 - x0, y1 - y0, z1 - z0) >= 1
        mine, owners = s.box_rows()
        # the nodes a box owns come first in its own order as its rows do: rows taken as they are at assembly
        np.testing.assert_array_equal(mine[owners == s.rank], np.arange(s.rows.lo, s.rows.hi))
        i, j, k = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1), np.arange(z0, z1 + 1), indexing="ij")
        np.testing.assert_array_equal(mine, rows[node_index(shape, i, j, k).ravel(order="F")])
        assert ("x0" in s.faces()) == (x0 == 0) and ("z1" in s.faces()) == (z1 == nz)
    assert sum(int(np.prod(s.box_shape)) for s in layouts) == nx * ny * nz


def test_process_grid_cuts_the_least_area() -> None:
    assert process_grid((6, 7, 8), 2) == (1, 1, 2)  # z-slabs when one cut suffices
    assert process_grid((64, 64, 64), 8) == (2, 2, 2)
    assert process_grid((64, 64, 8), 4) == (2, 2, 1)  # a flat image is cut across its large faces
    assert process_grid((6, 7, 8), 4, (2, 2, 1)) == (2, 2, 1)
    with pytest.raises(InputError, match=r"with \(5, 0, 0\) blocks"):
        process_grid((4, 4, 4), 5, (5, 0, 0))


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


def test_debian_petsc_is_found_without_hand_set_variables(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A Python that sees Debian's site directory gets PETSC_DIR / SLEPC_DIR set to the newest installed version
    (3.18 after 3.9: numbers compared as numbers) and their modules on sys.path; a variable set by hand, or a
    Python that does not see the site directory, is left alone."""
    from aromm import engines

    site = tmp_path / "dist-packages"
    site.mkdir()
    layout = []
    for var, name in (("PETSC_DIR", "petsc"), ("SLEPC_DIR", "slepc")):
        (site / f"{name}4py.pth").write_text("", encoding="utf-8")
        for version in ("3.9", "3.18"):
            (tmp_path / f"{name}dir" / f"{name}{version}" / "x86_64-linux-gnu-real").mkdir(parents=True)
        layout.append((var, str(tmp_path / f"{name}dir" / f"{name}3.*" / "*-real"), str(tmp_path / "absent"),
                       f"{name}4py.pth"))
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(engines, "DEBIAN_SITE", str(site))
    monkeypatch.setattr(engines, "DEBIAN_LAYOUT", tuple(layout))
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p != str(site)])
    assert engines.find_debian_petsc() == {}  # the site directory is not on sys.path
    monkeypatch.setattr(sys, "path", [*sys.path, str(site)])
    monkeypatch.setenv("SLEPC_DIR", "/by/hand")
    newest = str(tmp_path / "petscdir" / "petsc3.18" / "x86_64-linux-gnu-real")
    assert engines.find_debian_petsc() == {"PETSC_DIR": newest}
    assert os.environ["PETSC_DIR"] == newest and os.environ["SLEPC_DIR"] == "/by/hand"
    assert sys.path[-1] == os.path.join(newest, "lib", "python3", "dist-packages")
    assert engines.find_debian_petsc() == {}  # set once
