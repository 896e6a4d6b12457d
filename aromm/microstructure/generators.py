"""Synthetic voxel microstructures (label images indexed ``[x, y, z]``, PoreSpy style).

* :func:`wood` — spruce-like tracheids along z: walls = fibre (label 1), lumens = gas (label 0);
* :func:`sphere_in_cube` — one centred sphere (label 1) in a cube (label 0), the cell of [Hassan2019]
  (inclusion of radius L/3, volume fraction 4π/81 ≈ 15.51 %);
* :func:`simple_cubic` — a simple-cubic array of equal spheres at volume fraction φ [GarnierDanes];
* :func:`laminate` — flat layers across one axis (Wiener bounds, [GarnierDanes]).

Voxel ``(i, j, k)`` covers ``[i, i+1) × [j, j+1) × [k, k+1)`` voxel lengths; a voxel belongs to a
shape when its centre does.  Random generators take an explicit ``rng: np.random.Generator``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.microstructure.io import LabelImage, as_voxel_size

AXES = {"x": 0, "y": 1, "z": 2}
Generator = Callable[..., LabelImage]
#: Generators by the name a scene file uses (``[geometry] generator = "wood"``); :func:`generator` registers one.
GENERATORS: dict[str, Generator] = {}


def generator(function: Generator) -> Generator:
    """Register ``function`` under its own name for scene files (its keyword options become scene keys)."""
    GENERATORS[function.__name__] = function
    return function


def _positive_int(value: object, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise InputError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def _shape3(shape: object, name: str = "shape") -> tuple[int, int, int]:
    if not isinstance(shape, Sequence) or len(shape) != 3:
        raise InputError(f"{name} must be three positive integers (nx, ny, nz), got {shape!r}")
    nx, ny, nz = (_positive_int(n, name) for n in shape)
    return (nx, ny, nz)


def _axis(axis: object) -> int:
    if isinstance(axis, str) and axis in AXES:
        return AXES[axis]
    if isinstance(axis, int | np.integer) and not isinstance(axis, bool) and 0 <= axis <= 2:
        return int(axis)
    raise InputError(f"axis must be 0, 1, 2 or 'x', 'y', 'z', got {axis!r}")


def _ball(n: int, radius: float) -> npt.NDArray[np.bool_]:
    """Voxels of an ``n³`` cube whose centres lie within ``radius`` voxels of the cube centre."""
    c = (np.arange(n) + 0.5 - n / 2.0) ** 2
    return c[:, None, None] + c[None, :, None] + c[None, None, :] <= radius**2


@generator
def sphere_in_cube(n: int, radius_fraction: float = 1.0 / 3.0) -> LabelImage:
    """One sphere of radius ``radius_fraction · n`` voxels centred in an ``n³`` cube.

    Sphere = label 1, matrix = label 0.  The default radius L/3 is the inclusion of [Hassan2019]
    (§ "milieu hétérogène"), of volume fraction 4π/81 ≈ 0.1551, reached as ``n`` grows.
    ``radius_fraction`` must lie in (0, 1/2] (the sphere stays inside the cube).

    >>> labels = sphere_in_cube(30)
    >>> labels.shape, round(float(labels.mean()), 3), round(4 * np.pi / 81, 3)
    ((30, 30, 30), 0.156, 0.155)
    """
    n = _positive_int(n, "n")
    if not 0.0 < radius_fraction <= 0.5:
        raise InputError(f"radius_fraction must lie in (0, 0.5], got {radius_fraction!r}")
    return _ball(n, radius_fraction * n).astype(np.int32)


@generator
def simple_cubic(n_cells: int, cell_voxels: int, phi: float) -> LabelImage:
    """A simple-cubic array of ``n_cells³`` equal spheres (label 1) in a matrix (label 0).

    Each cubic cell of side a = ``cell_voxels`` voxels holds one centred sphere of radius
    r = a (3φ / 4π)^(1/3), so that the sphere volume fraction is φ; φ ∈ (0, π/6], the upper
    limit being touching spheres (r = a/2).  The image has ``n_cells · cell_voxels`` voxels a side;
    its voxel fraction tends to φ as ``cell_voxels`` grows.

    >>> labels = simple_cubic(2, 20, 0.3)
    >>> labels.shape, round(float(labels.mean()), 2)
    ((40, 40, 40), 0.3)
    """
    n_cells = _positive_int(n_cells, "n_cells")
    cell_voxels = _positive_int(cell_voxels, "cell_voxels")
    if not 0.0 < phi <= math.pi / 6.0:
        raise InputError(f"phi must lie in (0, π/6 = {math.pi / 6:.6f}] (touching spheres), got {phi!r}")
    radius_fraction = min((3.0 * phi / (4.0 * math.pi)) ** (1.0 / 3.0), 0.5)
    cell = sphere_in_cube(cell_voxels, radius_fraction)
    return np.tile(cell, (n_cells, n_cells, n_cells))


@generator
def laminate(
    shape: Sequence[int],
    axis: int | str,
    layer_voxels: Sequence[int] | None = None,
    *,
    fractions: Sequence[float] | None = None,
    labels: Sequence[int] | None = None,
) -> LabelImage:
    """Flat layers stacked along ``axis`` (0/'x', 1/'y', 2/'z'), each normal to that axis.

    Give the layer thicknesses either as ``layer_voxels`` (integers summing to ``shape[axis]``)
    or as ``fractions`` of ``shape[axis]`` (summing to 1, each times ``shape[axis]`` a whole number,
    so the volume fractions are exact).  Layer ``i`` gets ``labels[i]``, by default ``i % 2``
    (0, 1, 0, 1, …).

    >>> image = laminate((4, 2, 2), "x", fractions=(0.25, 0.75))
    >>> image[:, 0, 0].tolist()
    [0, 1, 1, 1]
    """
    nx, ny, nz = _shape3(shape)
    ax = _axis(axis)
    n = (nx, ny, nz)[ax]
    if (layer_voxels is None) == (fractions is None):
        raise InputError("laminate: give exactly one of layer_voxels or fractions")
    if fractions is not None:
        counts = [f * n for f in fractions]
        if any(f <= 0 for f in fractions) or abs(sum(fractions) - 1.0) > 1e-9:
            raise InputError(f"laminate: fractions must be positive and sum to 1, got {list(fractions)}")
        if any(abs(c - round(c)) > 1e-9 * n for c in counts):
            raise InputError(
                f"laminate: fractions × {n} voxels must be whole numbers for exact layers, got {counts}"
            )
        thicknesses = [round(c) for c in counts]
    else:
        assert layer_voxels is not None
        thicknesses = [_positive_int(t, "layer_voxels entries") for t in layer_voxels]
        if sum(thicknesses) != n:
            raise InputError(f"laminate: layer_voxels {thicknesses} sum to {sum(thicknesses)}, not shape[axis] = {n}")
    layer_labels = [i % 2 for i in range(len(thicknesses))] if labels is None else [int(v) for v in labels]
    if len(layer_labels) != len(thicknesses):
        raise InputError(f"laminate: {len(layer_labels)} labels for {len(thicknesses)} layers")
    profile = np.repeat(np.asarray(layer_labels, dtype=np.int32), thicknesses)
    view = [1, 1, 1]
    view[ax] = n
    return np.broadcast_to(profile.reshape(view), (nx, ny, nz)).copy()


def _wall_positions(
    rng: np.random.Generator, span: tuple[float, float], spacing: float, jitter: float, phase: float
) -> np.ndarray:
    """Wall centre lines from ``start - phase · spacing`` past ``stop`` (``span = (start, stop)``),
    gaps ``spacing (1 + jitter N(0, 1))`` clipped to [0.5, 1.5] × spacing; a fixed count of draws."""
    start, stop = span
    count = int((stop - start) / (0.5 * spacing)) + 3
    gaps = spacing * np.clip(1.0 + jitter * rng.standard_normal(count), 0.5, 1.5)
    positions = start - phase * spacing + np.concatenate([[0.0], np.cumsum(gaps)])
    return positions[: int(np.searchsorted(positions, stop)) + 1]


def _wall_mask(centres: np.ndarray, step: float, positions: np.ndarray, thickness: float) -> npt.NDArray[np.bool_]:
    """Voxels (centres along one axis, size ``step``) within ``thickness/2`` of a wall centre line, or
    holding one, so that a wall is never thinner than one voxel."""
    distance = np.min(np.abs(centres[..., None] - positions), axis=-1)
    return distance <= max(thickness, step) / 2.0


@generator
def wood(
    shape: Sequence[int],
    voxel_size: float | Sequence[float],
    rng: np.random.Generator,
    *,
    cell_size_radial: float = 25e-6,
    cell_size_tangential: float = 35e-6,
    wall_thickness: float = 5e-6,
    size_jitter: float = 0.15,
    stagger: float = 1.0,
    tracheid_length: float | None = None,
    grain_angle: float = 0.0,
) -> LabelImage:
    """Spruce-like softwood: tracheids along z with walls = fibre (label 1), lumens = gas (label 0).

    Cross-section (x = radial, y = tangential), as in spruce: radial files of cells side by side
    along y, separated by continuous radial walls (planes y = const); inside each file the cells
    follow each other along x, separated by tangential walls (planes x = const) whose positions are
    independent from file to file (``stagger`` = 1; 0 aligns them in a rectangular grid).
    Cell sizes along x and y are ``cell_size_radial`` and ``cell_size_tangential`` (m), each gap
    multiplied by ``1 + size_jitter · N(0, 1)`` (clipped to ×[0.5, 1.5]); walls are
    ``wall_thickness`` (m) thick but never thinner than one voxel.

    Tracheid tips: with ``tracheid_length`` (m) each radial file is cut along z into segments of
    that mean length (same jitter, random phase); at each cut the tracheids of the file end and new
    ones begin with freshly drawn tangential walls, so those walls are interrupted along z (the
    tapered tips overlap: no end wall).  ``None`` (default): tracheids cross the whole image.

    Spiral grain: ``grain_angle`` (radians) tilts the tracheid axis from z towards y, the pattern
    at height z being the base section shifted by z·tan(angle) along y.  Walls then leave the
    image through its y faces, which lowers k_zz (and raises k_yy slightly).

    Unequal radial and tangential cell sizes make k_xx ≠ k_yy ([Chavez2020, § 4.2] reports
    k̄_xx = 0.087, k̄_yy = 0.099, k̄_zz = 0.123 W/(m K)); the wall volume fraction sets c̄ (eq. 14).

    >>> labels = wood((46, 46, 46), 5e-6, np.random.default_rng(0))
    >>> labels.shape, bool(0.2 < labels.mean() < 0.6), sorted(np.unique(labels).tolist())
    ((46, 46, 46), True, [0, 1])
    """
    nx, ny, nz = _shape3(shape)
    dx, dy, dz = as_voxel_size(voxel_size, "wood: voxel_size")
    a, b, t = float(cell_size_radial), float(cell_size_tangential), float(wall_thickness)
    if not (t > 0 and a > t and b > t):
        raise InputError(
            f"wood: need 0 < wall_thickness < cell sizes, got radial {a!r}, tangential {b!r}, wall {t!r} (m)"
        )
    if not 0.0 <= size_jitter < 0.5:
        raise InputError(f"wood: size_jitter must lie in [0, 0.5), got {size_jitter!r}")
    if not 0.0 <= stagger <= 1.0:
        raise InputError(f"wood: stagger must lie in [0, 1], got {stagger!r}")
    if tracheid_length is not None and not tracheid_length > 0:
        raise InputError(f"wood: tracheid_length must be positive (m) or None, got {tracheid_length!r}")
    if not abs(grain_angle) < math.pi / 4:
        raise InputError(f"wood: grain_angle must lie in (-π/4, π/4) radians, got {grain_angle!r}")
    z_centres = (np.arange(nz) + 0.5) * dz
    # tangential coordinate of voxel centres in the frame of the (tilted) tracheids: [y, z]
    y_frame = (np.arange(ny) + 0.5)[:, None] * dy - math.tan(grain_angle) * z_centres[None, :]
    radial_walls = _wall_positions(rng, (float(y_frame.min()), float(y_frame.max())), b, size_jitter, rng.random())
    in_wall_y = _wall_mask(y_frame, dy, radial_walls, t)
    file_of_y = np.searchsorted(radial_walls, y_frame)
    n_files = radial_walls.size + 1
    if tracheid_length is None:
        segment_of_z = np.zeros((n_files, nz), dtype=int)
    else:
        segment_of_z = np.array(
            [
                np.searchsorted(
                    _wall_positions(rng, (0.0, nz * dz), tracheid_length, size_jitter, rng.random()), z_centres
                )
                for _ in range(n_files)
            ]
        )
    n_segments = int(segment_of_z.max()) + 1
    phase = rng.random()
    phases = (phase + stagger * rng.random((n_files, n_segments))) % 1.0
    x_centres = (np.arange(nx) + 0.5) * dx
    in_wall_x = np.array(
        [
            [_wall_mask(x_centres, dx, _wall_positions(rng, (0.0, nx * dx), a, size_jitter, ph), t) for ph in row]
            for row in phases
        ]
    )  # [file, segment, x]
    walls = in_wall_x[file_of_y, segment_of_z[file_of_y, np.arange(nz)[None, :]]]  # [y, z, x]
    return (walls.transpose(2, 0, 1) | in_wall_y[None, :, :]).astype(np.int32)
