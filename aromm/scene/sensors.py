"""Named sensors of a scene's ``[outputs]``: thermocouples, face patches and IR cameras as observation rows.

Besides face means (``mean_T``, aromm.core.vocabulary.face_means) a scene may observe its body through
named sensors; each is one or more rows ``e`` of the observation matrix, with ``e @ T`` the reading
(°C) and ``Σ e = 1`` (a weighted mean of the nodal temperatures):

=============  ======================================  ================================================
sensor         scene keys ([outputs.<name>])           row
=============  ======================================  ================================================
point          ``point = [x, y, z]`` (m)               the finite-element interpolant at the point:
                                                       ``T(x) = Σ_a φ_a(x) T_a`` (trilinear on voxels)
patch          ``face = "z1"``, optional               the mean over a rectangle of a face:
               ``x = [lo, hi]``, ``y = [lo, hi]``      ``e_a = ∫_R φ_a / |R|``
camera         ``face``, ``pixels = [n1, n2]``,        one patch per pixel of a regular grid over the
               optional window ``x = [..]`` ...        window (default the whole face)
=============  ======================================  ================================================

A patch's or camera's window is given on the face's two in-plane axes (``x``/``y`` on a z face,
``y``/``z`` on an x face, ``x``/``z`` on a y face); an axis left out spans the whole face.  A camera
named ``cam`` with ``pixels = [n1, n2]`` has the outputs ``cam_i_j`` (i < n1 along the first in-plane
axis, j < n2 along the second, both counted from the low coordinate), so a measurement CSV names its
columns ``t,cam_0_0,cam_0_1,...``.

On a voxel image the Q1 shape functions are products of 1-D hat functions, so every row is a
tensor product of 1-D weights (hat values at a coordinate, or hat integrals over an interval) and is
exact.  On a conforming mesh a point sensor uses the Lagrange interpolant of its element (P1 or P2,
found by barycentric coordinates); patches and cameras need the tensor structure of a voxel image
and are refused on mesh scenes.  Rows are sparse (a point touches 8 nodes, a pixel the nodes under
it), so a camera costs memory in proportion to the face, not to the body.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import FloatArray, Geometry, ThermalSystem
from aromm.core.vocabulary import AXES, FACES
from aromm.scene.geometry import MeshGeometry, SceneGeometry, VoxelGeometry

SENSOR_KEYS = ("point", "face", "x", "y", "z", "pixels")
NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]*\Z")
#: Relative tolerance (of the box size) for a point or window on the box's boundary.
EDGE_TOL = 1e-9
#: Barycentric tolerance for a point on an element's boundary (mesh scenes).
BARYCENTRIC_TOL = 1e-10
#: Most pixels of one camera (each is an output: a measurement column and a row of every model evaluation).
MAX_PIXELS = 65_536
MESH_FACE_SENSORS = ("face patches and cameras need a voxel scene (geometry.image or generator); a mesh scene "
                     "takes point sensors and mean_T")


@dataclass(frozen=True)
class PointSensor:
    """A thermocouple at ``point`` (x, y, z in m)."""

    name: str
    point: tuple[float, float, float]

    @property
    def outputs(self) -> tuple[str, ...]:
        return (self.name,)


@dataclass(frozen=True)
class FaceSensor:
    """The mean temperature over rectangles of ``face``: one patch (``pixels is None``) or a camera's pixel grid.

    ``window`` is ((lo, hi), (lo, hi)) in m on the face's two in-plane axes (in xyz order).
    """

    name: str
    face: str
    window: tuple[tuple[float, float], tuple[float, float]]
    pixels: tuple[int, int] | None = None

    @property
    def inplane(self) -> tuple[int, int]:
        """The face's two in-plane axes (0, 1, 2 for x, y, z), in xyz order."""
        normal = AXES.index(self.face[0])
        first, second = (ax for ax in range(3) if ax != normal)
        return first, second

    @property
    def outputs(self) -> tuple[str, ...]:
        if self.pixels is None:
            return (self.name,)
        return tuple(f"{self.name}_{i}_{j}" for i in range(self.pixels[0]) for j in range(self.pixels[1]))

    def rectangles(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        """The rectangles (in-plane ranges, m) of the outputs, in the order of :attr:`outputs`."""
        (u0, u1), (v0, v1) = self.window
        n1, n2 = self.pixels or (1, 1)
        us, vs = np.linspace(u0, u1, n1 + 1), np.linspace(v0, v1, n2 + 1)
        return [((float(us[i]), float(us[i + 1])), (float(vs[j]), float(vs[j + 1])))
                for i in range(n1) for j in range(n2)]


Sensor = PointSensor | FaceSensor


def output_names(sensors: Sequence[Sensor]) -> tuple[str, ...]:
    """Every output name of ``sensors`` in order (a camera contributes one per pixel)."""
    return tuple(name for s in sensors for name in s.outputs)


# ----------------------------------------------------------------- parsing ([outputs.<name>] tables)

def parse_sensors(table: Mapping[str, Any], box: tuple[FloatArray, FloatArray], faces: Sequence[str],
                  where: str = "", voxels: bool = True) -> tuple[Sensor, ...]:
    """Sensors from the sub-tables of ``[outputs]`` (every key but ``mean_T``); ``box`` = (lower, upper) corners (m).

    ``faces`` are the face-mean outputs already named (a sensor may not reuse a name); ``voxels`` is False for
    a mesh scene (point sensors only).  Refused with InputError naming ``outputs.<name>.<key>``: unknown
    keys, a point outside the box, a window outside the face or of zero width, pixel counts that are not
    positive integers, names that are not identifiers or clash with another output, a patch or camera on a
    mesh scene.
    """
    sensors: list[Sensor] = []
    for name, spec in table.items():
        key = f"outputs.{name}"

        def fail(sub: str, message: str, key: str = key) -> InputError:
            return InputError(f"{where}{key}{'.' + sub if sub else ''}: {message}")

        if not isinstance(spec, dict):
            raise fail("", "must be a table (a sensor: point = [x, y, z], or face = \"z1\" with optional x, y, z "
                           "ranges and pixels) or the key mean_T")
        if not NAME.match(name) or name in FACES or name == "t":
            raise fail("", f"sensor name {name!r} must be an identifier (letters, digits, _ or -) other than a face "
                           "name or 't'")
        unknown = sorted(set(spec) - set(SENSOR_KEYS))
        if unknown:
            raise fail(unknown[0], f"unknown key; allowed: {', '.join(SENSOR_KEYS)}")
        if ("point" in spec) == ("face" in spec):
            raise fail("", "give exactly one of point = [x, y, z] (a thermocouple) or face = \"<face>\" (a patch "
                           "or, with pixels, a camera)")
        if "face" in spec and not voxels:
            raise fail("face", MESH_FACE_SENSORS)
        sensors.append(_point(name, spec, box, fail) if "point" in spec else _face_sensor(name, spec, box, fail))
    counts = Counter([*faces, *output_names(sensors)])
    repeated = sorted(n for n, k in counts.items() if k > 1)
    if repeated:
        raise InputError(f"{where}outputs: output name(s) {repeated} appear twice (a camera 'cam' names its pixels "
                         "cam_i_j)")
    return tuple(sensors)


Fail = Callable[..., InputError]


def _number(value: Any, fail: Fail, sub: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise fail(sub, f"must hold finite numbers (m), got {value!r}")
    return float(value)


def _point(name: str, spec: Mapping[str, Any], box: tuple[FloatArray, FloatArray], fail: Fail) -> PointSensor:
    extra = sorted(set(spec) - {"point"})
    if extra:
        raise fail(extra[0], "a point sensor takes only point = [x, y, z]")
    raw = spec["point"]
    if not isinstance(raw, list) or len(raw) != 3:
        raise fail("point", f"must be [x, y, z] in m, got {raw!r}")
    p = np.array([_number(v, fail, "point") for v in raw])
    lo, hi = box
    tol = EDGE_TOL * float(np.max(hi - lo))
    if np.any(p < lo - tol) or np.any(p > hi + tol):
        raise fail("point", f"({', '.join(f'{v:g}' for v in p)}) m is outside the box "
                            f"[{', '.join(f'{a:g}..{b:g}' for a, b in zip(lo, hi, strict=True))}] m")
    x, y, z = np.clip(p, lo, hi)
    return PointSensor(name, (float(x), float(y), float(z)))


def _face_sensor(name: str, spec: Mapping[str, Any], box: tuple[FloatArray, FloatArray], fail: Fail) -> FaceSensor:
    face = spec["face"]
    if face not in FACES:
        raise fail("face", f"unknown face {face!r}; allowed: {', '.join(FACES)}")
    normal = AXES.index(face[0])
    if AXES[normal] in spec:
        raise fail(AXES[normal], f"face {face} is normal to {AXES[normal]}: give ranges of its in-plane axes only")
    lo, hi = box
    tol = EDGE_TOL * float(np.max(hi - lo))
    window = []
    for ax in (a for a in range(3) if a != normal):
        axis = AXES[ax]
        if axis not in spec:
            window.append((float(lo[ax]), float(hi[ax])))
            continue
        raw = spec[axis]
        if not isinstance(raw, list) or len(raw) != 2:
            raise fail(axis, f"must be [low, high] in m, got {raw!r}")
        a, b = (_number(v, fail, axis) for v in raw)
        if not b > a:
            raise fail(axis, f"empty range [{a:g}, {b:g}] m: give low < high")
        if a < lo[ax] - tol or b > hi[ax] + tol:
            raise fail(axis, f"[{a:g}, {b:g}] m is outside face {face} ({axis} from {lo[ax]:g} to {hi[ax]:g} m)")
        window.append((max(a, float(lo[ax])), min(b, float(hi[ax]))))
    pixels = None
    if "pixels" in spec:
        raw = spec["pixels"]
        if (not isinstance(raw, list) or len(raw) != 2
                or any(isinstance(v, bool) or not isinstance(v, int) or v < 1 for v in raw)):
            raise fail("pixels", f"must be two positive integers [n1, n2] (along the face's in-plane axes), "
                                 f"got {raw!r}")
        if raw[0] * raw[1] > MAX_PIXELS:
            raise fail("pixels", f"{raw[0]} x {raw[1]} pixels is more than {MAX_PIXELS}")
        pixels = (int(raw[0]), int(raw[1]))
    return FaceSensor(name, face, (window[0], window[1]), pixels)


# ----------------------------------------------------------------- observation rows

def hat_values(n_elements: int, h: float, x: float) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """Nodes and values of the 1-D linear hat functions (nodes at ``i h``) at the coordinate ``x``.

    >>> hat_values(4, 0.5, 0.6)
    (array([1, 2]), array([0.8, 0.2]))
    """
    s = x / h
    e = int(min(max(math.floor(s), 0), n_elements - 1))
    f = s - e
    return np.array([e, e + 1], dtype=np.int64), np.array([1.0 - f, f])


def hat_means(n_elements: int, h: float, lo: float, hi: float) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """Nodes and weights ``∫_lo^hi φ_i(u) du / (hi − lo)`` of the 1-D hat functions (they sum to one).

    On element [e h, (e+1) h] with ξ = u/h − e: ``∫ (1 − ξ) du = h [ξ − ξ²/2]``, ``∫ ξ du = h [ξ²/2]``.

    >>> hat_means(2, 1.0, 0.0, 2.0)[1].tolist()
    [0.25, 0.5, 0.25]
    """
    e = np.arange(n_elements)
    a = np.clip(lo / h - e, 0.0, 1.0)
    b = np.clip(hi / h - e, 0.0, 1.0)
    weights = np.zeros(n_elements + 1)
    np.add.at(weights, e, h * ((b - b**2 / 2) - (a - a**2 / 2)))
    np.add.at(weights, e + 1, h * (b**2 - a**2) / 2)
    weights /= hi - lo
    keep = np.flatnonzero(weights)
    return keep.astype(np.int64), weights[keep]


def _voxel_row(shape: tuple[int, int, int], parts: Sequence[tuple[npt.NDArray[np.int64], FloatArray]],
               n: int) -> sp.csr_array:
    """The tensor product of 1-D node weights along x, y, z as a (1, n) row (node i + (nx+1)(j + (ny+1)k))."""
    (ix, wx), (iy, wy), (iz, wz) = parts
    nx, ny, _ = shape
    nodes = (ix[:, None, None] + (nx + 1) * (iy[None, :, None] + (ny + 1) * iz[None, None, :])).ravel()
    weights = (wx[:, None, None] * wy[None, :, None] * wz[None, None, :]).ravel()
    row = sp.csr_array((weights, (np.zeros(nodes.size, dtype=np.int64), nodes)), shape=(1, n))
    row.sum_duplicates()
    return row


def voxel_rows(sensors: Sequence[Sensor], shape: tuple[int, int, int],
               voxel_size: tuple[float, float, float]) -> dict[str, sp.csr_array]:
    """Observation rows (1, n) of ``sensors`` on the Q1 voxel grid (aromm.fem.voxel node numbering)."""
    n = int(np.prod(np.asarray(shape) + 1))
    rows: dict[str, sp.csr_array] = {}
    for s in sensors:
        if isinstance(s, PointSensor):
            parts = [hat_values(shape[ax], voxel_size[ax], s.point[ax]) for ax in range(3)]
            rows[s.name] = _voxel_row(shape, parts, n)
            continue
        normal = AXES.index(s.face[0])
        side = (np.array([shape[normal] if s.face[1] == "1" else 0], dtype=np.int64), np.ones(1))
        p, q = s.inplane
        for out, (ur, vr) in zip(s.outputs, s.rectangles(), strict=True):
            parts = [side] * 3
            parts[p] = hat_means(shape[p], voxel_size[p], *ur)
            parts[q] = hat_means(shape[q], voxel_size[q], *vr)
            rows[out] = _voxel_row(shape, parts, n)
    return rows


def _monomials(x: FloatArray, degree: int) -> FloatArray:
    """Monomials of total degree ≤ ``degree`` (1 or 2) of the rows of ``x`` (m, 3): shape (m, 4) or (m, 10)."""
    cols = [np.ones(len(x)), x[:, 0], x[:, 1], x[:, 2]]
    if degree == 2:
        cols += [x[:, i] * x[:, j] for i in range(3) for j in range(i, 3)]
    return np.column_stack(cols)


_DEGREE = {"tetra": 1, "tetra10": 2}


def mesh_rows(sensors: Sequence[Sensor], geometry: Geometry, n: int, where: str = "") -> dict[str, sp.csr_array]:
    """Rows of point sensors on a simplex mesh: the Lagrange interpolant of the element holding the point.

    The element is found by its barycentric coordinates; the weights ``w`` solve ``Vᵀ w = m(x)`` with V the
    monomials (degree 1 or 2) at the element's nodes, which are the nodal shape functions' values at x.
    """
    rows: dict[str, sp.csr_array] = {}
    if geometry.cell_type not in _DEGREE:
        raise InputError(f"{where}outputs: point sensors need tetrahedra (P1 or P2), this mesh has "
                         f"{geometry.cell_type}")
    degree = _DEGREE[geometry.cell_type]
    points, cells = np.asarray(geometry.points, dtype=float), np.asarray(geometry.cells)
    corners = points[cells[:, :4]]
    edges = np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2)  # (n_cells, 3, 3), columns v_i − v_0
    for s in sensors:
        if isinstance(s, FaceSensor):
            raise InputError(f"{where}outputs.{s.name}: {MESH_FACE_SENSORS}")
        x = np.asarray(s.point)
        lam = np.linalg.solve(edges, (x - corners[:, 0])[..., None])[..., 0]
        bary = np.column_stack([1.0 - lam.sum(axis=1), lam])
        inside = np.flatnonzero(np.all(bary >= -BARYCENTRIC_TOL, axis=1))
        if inside.size == 0:
            raise InputError(f"{where}outputs.{s.name}.point: ({', '.join(f'{v:g}' for v in x)}) m lies in no "
                             "element of the mesh")
        nodes = cells[inside[0]]
        local = (points[nodes] - x) / float(np.ptp(points[nodes], axis=0).max())  # O(1) monomials
        w = np.linalg.solve(_monomials(local, degree).T, _monomials(np.zeros((1, 3)), degree)[0])
        row = sp.csr_array((w, (np.zeros(nodes.size, dtype=np.int64), nodes)), shape=(1, n))
        row.sum_duplicates()
        rows[s.name] = row
    return rows


def box(geometry: SceneGeometry) -> tuple[FloatArray, FloatArray]:
    """Lower and upper corners (m) of the scene's box: [0, size] for a voxel image, the bounding box of a mesh."""
    if isinstance(geometry, MeshGeometry):
        points = np.asarray(geometry.mesh.points, dtype=float)
        lo, hi = points.min(axis=0), points.max(axis=0)
        pad = np.zeros(3 - lo.size)
        return np.concatenate([lo, pad]), np.concatenate([hi, pad])
    return np.zeros(3), np.asarray(geometry.size, dtype=float)


def sensor_rows(sensors: Sequence[Sensor], geometry: SceneGeometry, system: ThermalSystem,
                where: str = "") -> dict[str, sp.csr_array]:
    """Observation rows of ``sensors`` on the discretisation of ``geometry`` that produced ``system``."""
    if isinstance(geometry, VoxelGeometry):
        return voxel_rows(sensors, geometry.shape, geometry.voxel_size)
    if system.geometry is None:
        raise InputError(f"{where}outputs: the system has no node coordinates to place sensors on")
    return mesh_rows(sensors, system.geometry, system.n, where)


def scene_rows(scene: Any, system: ThermalSystem, faces: Sequence[str]) -> dict[str, sp.csr_array]:
    """Observation rows of ``scene``'s sensors on the discretisation that produced ``system`` (whose face outputs
    were ``faces``): Q1 nodes or mesh elements (:func:`sensor_rows`), or finite volumes (:mod:`aromm.fv.observation`:
    the voxel centres and face temperatures)."""
    if scene.discretisation != "fv":
        return sensor_rows(scene.sensors, scene.geometry, system, scene.where)
    from aromm.fv.observation import patch_row, point_row
    from aromm.fv.volumes import volume_grid

    geo = scene.geometry
    grid = volume_grid(geo.labels, geo.voxel_size, scene.phases, scene.boundary, faces, steady=scene.time is None)
    rows: dict[str, sp.csr_array] = {}
    for s in scene.sensors:
        try:
            if isinstance(s, PointSensor):
                rows[s.name] = point_row(grid, s.point, s.name)
                continue
            for out, rect in zip(s.outputs, s.rectangles(), strict=True):
                rows[out] = patch_row(grid, s.face, rect, s.name)
        except InputError as err:
            raise InputError(f"{scene.where}{err}") from None
    return rows
