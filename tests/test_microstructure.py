"""Tests of aromm.microstructure: loaders, generators, export, and the shipped wood VER and scenes.

Truths checked are independent of the code under test: exact layer fractions, the sphere volume
4πr³/3, symmetry, hand-built byte layouts, meshio's own reader, [Chavez2020]'s published values.
"""

from __future__ import annotations

import importlib.util
import math
import tomllib
from pathlib import Path

import meshio
import numpy as np
import pytest
import tifffile
from hypothesis import given
from hypothesis import strategies as st

from aromm.core.errors import InputError
from aromm.microstructure import (
    export_image,
    export_time_series,
    laminate,
    load_image,
    save_image,
    simple_cubic,
    sphere_in_cube,
    voxel_mesh,
    wood,
)

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"


def coded(shape: tuple[int, int, int]) -> np.ndarray:
    """labels[i, j, k] = i + 10 j + 100 k: every voxel tells its own position."""
    i, j, k = np.meshgrid(*(np.arange(n) for n in shape), indexing="ij")
    return (i + 10 * j + 100 * k).astype(np.uint16)


# ---------------------------------------------------------------- loaders


def test_npy_round_trip(tmp_path: Path) -> None:
    image = coded((3, 4, 5))
    np.save(tmp_path / "a.npy", image)
    labels, voxel = load_image(tmp_path / "a.npy")
    assert voxel is None
    assert labels.dtype == np.int32
    np.testing.assert_array_equal(labels, image)


@pytest.mark.parametrize("voxel", [5e-6, [1e-6, 2e-6, 3e-6]])
def test_npz_round_trip_with_voxel_size(tmp_path: Path, voxel: object) -> None:
    image = coded((3, 4, 5))
    np.savez(tmp_path / "a.npz", labels=image, voxel_size=np.asarray(voxel))
    labels, size = load_image(tmp_path / "a.npz")
    np.testing.assert_array_equal(labels, image)
    assert size == ((5e-6,) * 3 if np.isscalar(voxel) else (1e-6, 2e-6, 3e-6))
    saved = save_image(tmp_path / "b.npz", labels, size)
    again, size_again = load_image(saved)
    np.testing.assert_array_equal(again, image)
    assert size_again == size


def test_npz_without_voxel_size(tmp_path: Path) -> None:
    np.savez(tmp_path / "a.npz", labels=np.ones((2, 2, 2), dtype=np.uint8))
    assert load_image(tmp_path / "a.npz")[1] is None


def test_tiff_stack_pages_are_z_slices_rows_y_columns_x(tmp_path: Path) -> None:
    image = coded((3, 4, 5))
    with tifffile.TiffWriter(tmp_path / "stack.tif") as tif:
        for k in range(5):  # one page per z, written by hand: page[row=j, col=i]
            tif.write(np.array([[image[i, j, k] for i in range(3)] for j in range(4)], dtype=np.uint16))
    labels, voxel = load_image(tmp_path / "stack.tif")
    assert voxel is None
    np.testing.assert_array_equal(labels, image)


def test_tiff_directory_sorted_numerically(tmp_path: Path) -> None:
    image = coded((3, 4, 12))
    for k in range(12):  # names slice_1 ... slice_12: a plain sort would put 10 before 2
        tifffile.imwrite(tmp_path / f"slice_{k + 1}.tif", image[:, :, k].T.copy())
    (tmp_path / "notes.txt").write_text("ignored")
    labels, _ = load_image(tmp_path)
    np.testing.assert_array_equal(labels, image)


def test_raw_is_x_fastest(tmp_path: Path) -> None:
    image = coded((3, 4, 5))
    values = [int(image[i, j, k]) for k in range(5) for j in range(4) for i in range(3)]
    np.asarray(values, dtype="<u2").tofile(tmp_path / "block.raw")
    labels, voxel = load_image(tmp_path / "block.raw", shape=(3, 4, 5), dtype="<u2")
    assert voxel is None
    np.testing.assert_array_equal(labels, image)


def test_raw_default_dtype_is_uint8(tmp_path: Path) -> None:
    np.arange(8, dtype=np.uint8).tofile(tmp_path / "b.bin")
    labels, _ = load_image(tmp_path / "b.bin", shape=(2, 2, 2))
    assert labels[1, 1, 1] == 7


def test_booleans_and_whole_floats_accepted(tmp_path: Path) -> None:
    np.save(tmp_path / "b.npy", np.eye(3, dtype=bool)[:, :, None].repeat(2, axis=2))
    assert load_image(tmp_path / "b.npy")[0].sum() == 6
    np.save(tmp_path / "f.npy", np.full((2, 2, 2), 3.0))
    assert set(load_image(tmp_path / "f.npy")[0].ravel().tolist()) == {3}


def _bad_files(tmp: Path) -> dict[str, tuple[Path, dict, str]]:
    """name -> (file, load_image keywords, fragment the message must contain)."""
    np.save(tmp / "flat.npy", np.zeros((4, 4), dtype=np.uint8))
    np.save(tmp / "grey.npy", np.full((2, 2, 2), 0.5))
    np.save(tmp / "nan.npy", np.full((2, 2, 2), np.nan))
    np.save(tmp / "pickled.npy", np.array([{"a": 1}] * 8, dtype=object).reshape(2, 2, 2), allow_pickle=True)
    np.save(tmp / "empty.npy", np.zeros((0, 2, 2), dtype=np.uint8))
    np.savez(tmp / "wrongkey.npz", image=np.zeros((2, 2, 2), dtype=np.uint8))
    np.savez(tmp / "badvoxel.npz", labels=np.zeros((2, 2, 2), dtype=np.uint8), voxel_size=np.array(-1.0))
    np.savez(tmp / "twovoxel.npz", labels=np.zeros((2, 2, 2), dtype=np.uint8), voxel_size=np.array([1.0, 2.0]))
    (tmp / "corrupt.npz").write_bytes(b"not a zip archive")
    (tmp / "corrupt.tif").write_bytes(b"not a tiff")
    np.zeros(7, dtype=np.uint8).tofile(tmp / "short.raw")
    tifffile.imwrite(tmp / "page.tif", np.zeros((4, 4), dtype=np.uint8))
    (tmp / "empty_dir").mkdir()
    (tmp / "ragged").mkdir()
    tifffile.imwrite(tmp / "ragged" / "s1.tif", np.zeros((4, 4), dtype=np.uint8))
    tifffile.imwrite(tmp / "ragged" / "s2.tif", np.zeros((4, 5), dtype=np.uint8))
    np.save(tmp / "ok.npy", np.zeros((2, 2, 2), dtype=np.uint8))
    (tmp / "archive.npy").write_bytes((tmp / "wrongkey.npz").read_bytes())
    return {
        "missing": (tmp / "nope.npy", {}, "no such file"),
        "not 3-D": (tmp / "flat.npy", {}, "3-D"),
        "non-integer": (tmp / "grey.npy", {}, "integers"),
        "nan": (tmp / "nan.npy", {}, "integers"),
        "pickle": (tmp / "pickled.npy", {}, "not a readable .npy"),
        "empty": (tmp / "empty.npy", {}, "empty"),
        "wrong key": (tmp / "wrongkey.npz", {}, "no key 'labels'"),
        "bad voxel": (tmp / "badvoxel.npz", {}, "voxel size"),
        "two voxel values": (tmp / "twovoxel.npz", {}, "voxel size"),
        "corrupt npz": (tmp / "corrupt.npz", {}, "not a readable .npz"),
        "corrupt tiff": (tmp / "corrupt.tif", {}, "not a readable TIFF"),
        "raw size": (tmp / "short.raw", {"shape": (2, 2, 2)}, "7 bytes"),
        "raw bad shape": (tmp / "short.raw", {"shape": (2, 2)}, "three positive integers"),
        "raw bad dtype": (tmp / "short.raw", {"shape": (7, 1, 1), "dtype": "nonsense"}, "dtype"),
        "raw without shape": (tmp / "short.raw", {}, "unknown image format"),
        "dtype not raw": (tmp / "ok.npy", {"dtype": "uint8"}, "raw files only"),
        "shape mismatch": (tmp / "ok.npy", {"shape": (2, 2, 3)}, "differs"),
        "2-D tiff": (tmp / "page.tif", {}, "2-D"),
        "empty dir": (tmp / "empty_dir", {}, "no .tif"),
        "ragged slices": (tmp / "ragged", {}, "differs"),
        "npz named npy": (tmp / "archive.npy", {}, "rename it to .npz"),
    }


BAD_CASES = [
    "missing", "not 3-D", "non-integer", "nan", "pickle", "empty", "wrong key", "bad voxel", "two voxel values",
    "corrupt npz", "corrupt tiff", "raw size", "raw bad shape", "raw bad dtype", "raw without shape",
    "dtype not raw", "shape mismatch", "2-D tiff", "empty dir", "ragged slices", "npz named npy",
]


@pytest.mark.parametrize("case", BAD_CASES)
def test_bad_input_raises_input_error_naming_the_file(tmp_path: Path, case: str) -> None:
    cases = _bad_files(tmp_path)
    path, kwargs, fragment = cases[case]
    with pytest.raises(InputError) as info:
        load_image(path, **kwargs)
    message = str(info.value)
    assert path.name in message
    assert fragment in message


# ---------------------------------------------------------------- generators


@pytest.mark.parametrize("axis", [0, 1, 2, "x", "y", "z"])
def test_laminate_fractions_exact(axis: int | str) -> None:
    shape = (8, 12, 16)
    ax = "xyz".index(axis) if isinstance(axis, str) else axis
    n = shape[ax]
    image = laminate(shape, axis, fractions=(0.25, 0.75) if n != 12 else (1 / 3, 2 / 3))
    expected = 0.75 if n != 12 else 2 / 3
    assert image.mean() == pytest.approx(expected, abs=1e-12)
    # layers are normal to the axis: constant over every plane normal to it
    assert all(np.unique(np.take(image, i, axis=ax)).size == 1 for i in range(n))


@given(st.lists(st.integers(1, 5), min_size=1, max_size=6), st.sampled_from("xyz"))
def test_laminate_layer_fractions_property(layers: list[int], axis: str) -> None:
    shape = [3, 3, 3]
    shape["xyz".index(axis)] = sum(layers)
    image = laminate(tuple(shape), axis, layers)
    odd = sum(layers[1::2])
    assert image.sum() == odd * image.size // sum(layers)  # label 1 on odd layers, exactly


def test_laminate_layer_voxels_and_labels() -> None:
    image = laminate((6, 1, 1), "x", [1, 2, 3], labels=[5, 7, 5])
    assert image[:, 0, 0].tolist() == [5, 7, 7, 5, 5, 5]


@pytest.mark.parametrize(
    ("args", "kwargs"),
    [
        (((10, 10, 10), "z"), {"fractions": (0.33, 0.67)}),
        (((10, 10, 10), "z"), {"fractions": (0.5, 0.6)}),
        (((10, 10, 10), "z", [3, 3]), {}),
        (((10, 10, 10), "w", [5, 5]), {}),
        (((10, 10, 10), "z"), {}),
        (((10, 10, 10), "z", [5, 5]), {"labels": [1]}),
    ],
)
def test_laminate_refuses(args: tuple, kwargs: dict) -> None:
    with pytest.raises(InputError):
        laminate(*args, **kwargs)


def test_sphere_in_cube_volume_fraction_converges_to_4pi_over_81() -> None:
    exact = 4 * math.pi / 81
    errors = [abs(sphere_in_cube(n).mean() - exact) for n in (15, 30, 60, 120)]
    assert errors[-1] < 2e-3 * exact
    assert errors[-1] < errors[0] / 4  # voxel surface error decreases (about as 1/n, noisily)


def test_sphere_in_cube_is_symmetric() -> None:
    image = sphere_in_cube(17, 0.4)
    for axis in range(3):
        np.testing.assert_array_equal(image, np.flip(image, axis))
    np.testing.assert_array_equal(image, image.transpose(1, 2, 0))
    assert image[8, 8, 8] == 1 and image[0, 0, 0] == 0


@pytest.mark.parametrize("phi", [0.05, 0.2, 0.4, math.pi / 6])
def test_simple_cubic_fraction_matches_phi(phi: float) -> None:
    image = simple_cubic(2, 40, phi)
    assert image.shape == (80, 80, 80)
    assert image.mean() == pytest.approx(phi, rel=0.02)
    np.testing.assert_array_equal(image[:40, :40, :40], image[40:, 40:, 40:])  # periodic cells


@pytest.mark.parametrize("phi", [0.0, 0.6, -0.1])
def test_simple_cubic_refuses_phi_out_of_range(phi: float) -> None:
    with pytest.raises(InputError, match="phi"):
        simple_cubic(1, 10, phi)


def _mean_run(gas: np.ndarray, axis: int) -> float:
    """Mean length (voxels) of runs of gas along ``axis`` that do not touch the image border."""
    line = np.moveaxis(gas, axis, -1).reshape(-1, gas.shape[axis]).astype(np.int8)
    edges = np.diff(np.pad(line, ((0, 0), (1, 1))), axis=1)
    runs = []
    for row in edges:
        starts, stops = np.flatnonzero(row == 1), np.flatnonzero(row == -1)
        runs += [b - a for a, b in zip(starts, stops, strict=True) if a > 0 and b < gas.shape[axis]]
    return float(np.mean(runs))


def test_wood_radial_and_tangential_cell_sizes() -> None:
    image = wood((60, 60, 4), 1e-6, np.random.default_rng(1), cell_size_radial=10e-6,
                 cell_size_tangential=20e-6, wall_thickness=2e-6, size_jitter=0.1)
    gas = image == 0
    # lumen chords: cell size minus one wall (2 voxels), within jitter/sampling
    assert _mean_run(gas, 0) == pytest.approx(8.0, rel=0.15)
    assert _mean_run(gas, 1) == pytest.approx(18.0, rel=0.15)
    assert set(np.unique(image).tolist()) == {0, 1}


def test_wood_is_prismatic_without_tips_or_grain() -> None:
    image = wood((30, 30, 10), 5e-6, np.random.default_rng(2))
    assert all(np.array_equal(image[:, :, k], image[:, :, 0]) for k in range(10))


def test_wood_tracheid_tips_change_sections() -> None:
    image = wood((30, 30, 40), 5e-6, np.random.default_rng(2), tracheid_length=50e-6)
    changed = [not np.array_equal(image[:, :, k], image[:, :, 0]) for k in range(40)]
    assert any(changed)
    # radial walls (planes y = const) are not cut by tips: rows of wall across all x stay put
    full_rows = [set(np.flatnonzero(image[:, :, k].all(axis=0))) for k in range(40)]
    assert all(rows == full_rows[0] for rows in full_rows)


def test_wood_grain_angle_shifts_sections_along_y() -> None:
    # tan(angle) = 1/5 with cubic voxels: section k = 5 is section 0 moved by one voxel along +y
    image = wood((30, 30, 10), 5e-6, np.random.default_rng(4), grain_angle=math.atan(0.2))
    np.testing.assert_array_equal(image[:, 1:, 5], image[:, :-1, 0])
    assert not np.array_equal(image[:, :, 5], image[:, :, 0])


def test_wood_reproducible_with_seed_and_different_otherwise() -> None:
    args = ((24, 24, 24), 5e-6)
    options = {"tracheid_length": 60e-6, "grain_angle": 0.1}
    a = wood(*args, np.random.default_rng(7), **options)
    b = wood(*args, np.random.default_rng(7), **options)
    c = wood(*args, np.random.default_rng(8), **options)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize(
    "options",
    [
        {"wall_thickness": 30e-6},
        {"wall_thickness": -1e-6},
        {"size_jitter": 0.6},
        {"stagger": 2.0},
        {"tracheid_length": 0.0},
        {"grain_angle": 1.0},
    ],
)
def test_wood_refuses_bad_options(options: dict) -> None:
    with pytest.raises(InputError, match="wood"):
        wood((10, 10, 10), 5e-6, np.random.default_rng(0), **options)


def test_generators_refuse_bad_sizes() -> None:
    with pytest.raises(InputError):
        sphere_in_cube(0)
    with pytest.raises(InputError):
        sphere_in_cube(10, 0.6)
    with pytest.raises(InputError, match="voxel size"):
        wood((10, 10, 10), -5e-6, np.random.default_rng(0))
    with pytest.raises(InputError, match="shape"):
        wood((10, 10), 5e-6, np.random.default_rng(0))


# ---------------------------------------------------------------- export


def test_voxel_mesh_hexahedra_are_the_voxels() -> None:
    shape, voxel = (3, 2, 4), (1.0, 2.0, 3.0)
    points, hexes = voxel_mesh(shape, voxel)
    assert points.shape == (4 * 3 * 5, 3)
    assert hexes.shape == (24, 8)
    corners = points[hexes]  # (cells, 8, 3)
    np.testing.assert_allclose(corners[:, 1] - corners[:, 0], np.tile([1.0, 0, 0], (24, 1)))
    np.testing.assert_allclose(corners[:, 3] - corners[:, 0], np.tile([0, 2.0, 0], (24, 1)))
    np.testing.assert_allclose(corners[:, 4] - corners[:, 0], np.tile([0, 0, 3.0], (24, 1)))
    np.testing.assert_allclose(corners[:, 6] - corners[:, 0], np.tile([1.0, 2.0, 3.0], (24, 1)))
    # voxel (i, j, k) = cell i + nx (j + ny k) has its lowest corner at (i dx, j dy, k dz)
    np.testing.assert_allclose(corners[1 + 3 * (1 + 2 * 2), 0], [1.0, 2.0, 6.0])


def read_xdmf(path: Path) -> meshio.Mesh:
    """meshio.read needs h5py even for inline XDMF; meshio's time-series reader does not."""
    with meshio.xdmf.TimeSeriesReader(path) as reader:
        points, cells = reader.read_points_cells()
        assert reader.num_steps == 1
        _, point_data, cell_data = reader.read_data(0)
    return meshio.Mesh(points, cells, point_data=point_data, cell_data=cell_data)


@pytest.mark.parametrize("suffix", [".vtu", ".xdmf"])
def test_export_round_trip(tmp_path: Path, suffix: str) -> None:
    labels = coded((3, 4, 5)) % 3
    nx, ny, nz = labels.shape
    dx, dy, dz = 1e-3, 2e-3, 3e-3
    # a nodal field defined from the node-order formula alone: T = x + 10 y + 100 z at node (i, j, k)
    t = np.zeros((nx + 1) * (ny + 1) * (nz + 1))
    for k in range(nz + 1):
        for j in range(ny + 1):
            for i in range(nx + 1):
                t[i + (nx + 1) * (j + (ny + 1) * k)] = i * dx + 10 * j * dy + 100 * k * dz
    cell_field = np.arange(labels.size, dtype=float)
    path = export_image(tmp_path / f"img{suffix}", labels, (dx, dy, dz), {"T": t, "id": cell_field})
    mesh = meshio.read(path) if suffix == ".vtu" else read_xdmf(path)
    p = mesh.points
    np.testing.assert_allclose(mesh.point_data["T"], p[:, 0] + 10 * p[:, 1] + 100 * p[:, 2], atol=1e-12)
    assert mesh.cells[0].type == "hexahedron" and len(mesh.cells[0].data) == labels.size
    np.testing.assert_array_equal(mesh.cell_data["labels"][0], labels.ravel(order="F"))
    # cell data follow the voxels: centre of the cell where labels were written
    centres = p[mesh.cells[0].data].mean(axis=1)
    idx = np.floor(centres / [dx, dy, dz]).astype(int)
    np.testing.assert_array_equal(mesh.cell_data["labels"][0], labels[idx[:, 0], idx[:, 1], idx[:, 2]])
    np.testing.assert_array_equal(mesh.cell_data["id"][0], cell_field)


def test_export_accepts_3d_nodal_arrays(tmp_path: Path) -> None:
    labels = np.zeros((2, 3, 4), dtype=int)
    nodal = np.random.default_rng(0).random((3, 4, 5))
    mesh = meshio.read(export_image(tmp_path / "a.vtu", labels, 1.0, {"T": nodal}))
    idx = np.rint(mesh.points).astype(int)
    np.testing.assert_allclose(mesh.point_data["T"], nodal[idx[:, 0], idx[:, 1], idx[:, 2]])


def test_export_time_series_round_trip(tmp_path: Path) -> None:
    labels = np.ones((2, 2, 2), dtype=int)
    series = np.outer([0.0, 1.0, 3.0], np.arange(27.0))
    path = export_time_series(tmp_path / "run.xdmf", labels, 1e-3, [0.0, 0.5, 1.0], {"T": series})
    with meshio.xdmf.TimeSeriesReader(path) as reader:
        reader.read_points_cells()
        steps = [reader.read_data(i) for i in range(reader.num_steps)]
    assert [s[0] for s in steps] == [0.0, 0.5, 1.0]
    for row, (_, point_data, _) in zip(series, steps, strict=True):
        np.testing.assert_allclose(point_data["T"], row)


def test_export_refuses_bad_input(tmp_path: Path) -> None:
    labels = np.zeros((2, 2, 2), dtype=int)
    with pytest.raises(InputError, match=r"a\.vtk"):
        export_image(tmp_path / "a.vtk", labels, 1.0)
    with pytest.raises(InputError, match="field 'T'"):
        export_image(tmp_path / "a.vtu", labels, 1.0, {"T": np.zeros(26)})
    with pytest.raises(InputError, match="non-finite"):
        export_image(tmp_path / "a.vtu", labels, 1.0, {"T": np.full(27, np.nan)})
    with pytest.raises(InputError, match="increasing"):
        export_time_series(tmp_path / "b.xdmf", labels, 1.0, [1.0, 0.0], {"T": np.zeros((2, 27))})
    with pytest.raises(InputError, match=r"b\.vtu"):
        export_time_series(tmp_path / "b.vtu", labels, 1.0, [0.0], {"T": np.zeros((1, 27))})


# ---------------------------------------------------------------- shipped data and scenes

SEED_001_K = np.array([0.087, 0.099, 0.123])  # W/(m K), [Chavez2020, § 4.2]
SEED_001_C = 1.558e6  # J/(m^3 K)
K_F, K_G, C_F, C_G = 0.3, 0.025, 4.0e6, 1.2e3


def test_wood_ver_file_and_capacity() -> None:
    labels, voxel = load_image(DATA / "wood_ver.npz")
    assert labels.shape == (46, 46, 46)
    assert voxel == (5.0e-6,) * 3
    assert set(np.unique(labels).tolist()) == {0, 1}
    phi = labels.mean()
    assert phi * C_F + (1 - phi) * C_G == pytest.approx(SEED_001_C, rel=0.05)  # eq. 14


def test_wood_ver_is_reproduced_by_its_generator_call() -> None:
    spec = importlib.util.spec_from_file_location("make_wood_ver", ROOT / "scripts" / "make_wood_ver.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    labels, _ = load_image(DATA / "wood_ver.npz")
    np.testing.assert_array_equal(script.make(script.SEED, script.PARAMS), labels)


SCENARIOS = {"wood_s1": "z", "wood_s2": "x", "wood_s3": "y"}  # [Chavez2020, Table 1] via docs/design.md


@pytest.mark.parametrize(("name", "axis"), sorted(SCENARIOS.items()))
def test_wood_scenes_follow_table_1(name: str, axis: str) -> None:
    path = DATA / "scenes" / f"{name}.toml"
    scene = tomllib.loads(path.read_text())
    assert (path.parent / scene["geometry"]["image"]).resolve() == (DATA / "wood_ver.npz").resolve()
    assert scene["boundary"] == {f"{axis}0": {"flux": 500.0}, f"{axis}1": {"h": 20.0, "T_ext": 0.0}}
    assert scene["phases"] == {"fibre": {"label": 1, "k": K_F, "c": C_F}, "gas": {"label": 0, "k": K_G, "c": C_G}}
    assert scene["initial"] == {"T": 0.0}
    assert scene["time"] == {"end": 60.0, "dt": 0.1}
    assert scene["outputs"] == {"mean_T": [f"{axis}0", f"{axis}1"]}


@pytest.mark.parametrize("name", ["wood_s1", "wood_s2", "wood_s3", "wood_homogenize", "sphere_steady"])
def test_scenes_load(name: str) -> None:
    scene_module = pytest.importorskip("aromm.scene.scene_file")
    scene = scene_module.load_scene(DATA / "scenes" / f"{name}.toml")
    assert scene.geometry.labels.ndim == 3


def test_sphere_scene_is_the_seed_000_cell() -> None:
    scene = pytest.importorskip("aromm.scene.scene_file").load_scene(DATA / "scenes" / "sphere_steady.toml")
    assert scene.size == pytest.approx((0.1, 0.1, 0.1))
    assert scene.volume_fractions()["inclusion"] == pytest.approx(4 * math.pi / 81, rel=0.05)


def test_wood_ver_is_reproduced_by_a_generator_scene() -> None:
    scene_module = pytest.importorskip("aromm.scene.scene_file")
    geometry = {"generator": "wood", "shape": [46, 46, 46], "voxel_size": 5.0e-6, "seed": 347,
                "cell_size_radial": 19.7e-6, "cell_size_tangential": 29.2e-6, "wall_thickness": 4.76e-6,
                "size_jitter": 0.147, "tracheid_length": 134e-6, "grain_angle": 0.150}
    phases = {"fibre": {"label": 1, "k": K_F}, "gas": {"label": 0, "k": K_G}}
    scene = scene_module.scene_from_dict({"geometry": geometry, "phases": phases})
    np.testing.assert_array_equal(scene.geometry.labels, load_image(DATA / "wood_ver.npz")[0])


@pytest.mark.slow
def test_wood_ver_homogenised_conductivity_matches_seed_001() -> None:
    """Eq. 13 on the shipped VER against [Chavez2020, § 4.2] (a few seconds idle, minutes on a loaded machine):
    under the three scenarios' own faces, as the seed does and as the VER was tuned, within 1.5 %;
    with an isothermal S2 (`aromm.homogenize`) within issue 2's 5 %."""
    homogenize = pytest.importorskip("aromm.homogenize")
    load_scene = pytest.importorskip("aromm.scene.scene_file").load_scene
    scene = load_scene(DATA / "scenes" / "wood_homogenize.toml")
    k = homogenize.homogenize(scene, boundary="flux", method="amg")
    np.testing.assert_allclose(np.diag(k), SEED_001_K, rtol=0.05)
    scenarios = [load_scene(DATA / "scenes" / f"wood_s{i}.toml") for i in (2, 3, 1)]  # loaded along x, y, z
    k_scenario = [homogenize.fluxmetric(sc, method="amg").k for sc in scenarios]
    np.testing.assert_allclose(k_scenario, SEED_001_K, rtol=0.015)
    assert homogenize.mean_capacity(scene) == pytest.approx(SEED_001_C, rel=0.015)
