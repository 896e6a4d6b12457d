"""Export voxel label images (and nodal or voxel fields on them) for ParaView, through meshio.

The mesh is one hexahedron per voxel.  Nodes are numbered x fastest,
``node(i, j, k) = i + (nx+1) (j + (ny+1) k)`` with coordinates ``(i dx, j dy, k dz)`` in metres,
the node order of the finite-element assembly (aromm.fem.voxel); voxels likewise
``cell(i, j, k) = i + nx (j + ny k)``.  Cell data ``labels`` holds the phase labels.

Formats by file name: ``.vtu`` (VTK XML unstructured grid, zlib-compressed binary) and
``.xdmf``/``.xmf`` (XDMF with the data inline as XML, so no HDF5 library is needed).  XDMF is
written through meshio's time-series writer (the only meshio XDMF path that works without h5py),
so a single image is a one-step temporal collection at t = 0; read it back with
``meshio.xdmf.TimeSeriesReader`` (``meshio.read`` on XDMF needs h5py).  VTK's readers (those of
ParaView: vtkXMLUnstructuredGridReader, vtkXdmfReader, VTK 9.7) read both formats with the right
hexahedra (volumes dx dy dz), labels and fields; on XDMF they show a second block, ``mesh``, which is
meshio's shared geometry — colour by the ``TimeSeries_meshio`` block.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import meshio
import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.fem.voxel_grid import VTK_HEX, connectivity, node_points
from aromm.microstructure.io import as_labels, as_voxel_size

FORMATS = {".vtu": "vtu", ".xdmf": "xdmf", ".xmf": "xdmf"}


def voxel_mesh(shape: Sequence[int], voxel_size: float | Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """Node coordinates ``(n_nodes, 3)`` (m) and hexahedra ``(n_voxels, 8)`` (VTK corner order), voxels x fastest.

    The nodes and corners of the finite-element assembly (:mod:`aromm.fem.voxel`).

    >>> points, hexes = voxel_mesh((2, 1, 1), 1.0)
    >>> points.shape, hexes.tolist()
    ((12, 3), [[0, 1, 4, 3, 6, 7, 10, 9], [1, 2, 5, 4, 7, 8, 11, 10]])
    """
    grid = (int(shape[0]), int(shape[1]), int(shape[2]))
    size = as_voxel_size(voxel_size)
    x_fastest = np.ravel_multi_index(np.unravel_index(np.arange(int(np.prod(grid))), grid, order="F"), grid)
    return node_points(grid, size), connectivity(grid, x_fastest)[:, VTK_HEX]


def _split_fields(
    fields: Mapping[str, npt.ArrayLike], shape: tuple[int, int, int], path: Path
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Sort fields into point data (one value per node) and cell data (one per voxel)."""
    node_shape = tuple(n + 1 for n in shape)
    n_nodes, n_cells = int(np.prod(node_shape)), int(np.prod(shape))
    points: dict[str, np.ndarray] = {}
    cells: dict[str, np.ndarray] = {}
    for name, value in fields.items():
        arr = np.asarray(value, dtype=float)
        if arr.shape in (node_shape, shape):
            arr = arr.ravel(order="F")
        if arr.shape == (n_nodes,):
            points[name] = arr
        elif arr.shape == (n_cells,):
            cells[name] = arr
        else:
            raise InputError(
                f"{path}: field {name!r} has shape {np.shape(value)}; allowed: {n_nodes} node values"
                f" (or {node_shape}) ordered x fastest, or {n_cells} voxel values (or {shape})"
            )
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{path}: field {name!r} holds non-finite values")
    return points, cells


def _format(path: Path, allowed: Mapping[str, str]) -> str:
    kind = allowed.get(path.suffix.lower())
    if kind is None:
        raise InputError(f"{path}: unknown export format {path.suffix!r}; allowed: {', '.join(allowed)}")
    return kind


def export_image(
    path: str | Path,
    labels: npt.ArrayLike,
    voxel_size: float | Sequence[float],
    fields: Mapping[str, npt.ArrayLike] | None = None,
) -> Path:
    """Write the voxel image as hexahedra (cell data ``labels``) to ``.vtu`` or ``.xdmf``; return the path.

    ``fields`` maps names to node values — ``(nx+1)(ny+1)(nz+1)`` values in the order
    ``i + (nx+1)(j + (ny+1)k)`` (x fastest), or an array shaped ``(nx+1, ny+1, nz+1)`` — or to
    voxel values (``nx ny nz`` values x fastest, or an array shaped like ``labels``).

    >>> import tempfile, pathlib
    >>> labels = np.zeros((2, 2, 2), dtype=int)
    >>> file = export_image(pathlib.Path(tempfile.mkdtemp()) / "cube.vtu", labels, 1e-3, {"T": np.arange(27.0)})
    >>> mesh = meshio.read(file)
    >>> mesh.points.shape, mesh.cells[0].type, float(mesh.point_data["T"][5])
    ((27, 3), 'hexahedron', 5.0)
    """
    path = Path(path)
    kind = _format(path, FORMATS)
    image = as_labels(labels, str(path))
    points, hexes = voxel_mesh(image.shape, voxel_size)
    point_data, cell_data = _split_fields(fields or {}, image.shape, path)
    mesh = meshio.Mesh(
        points,
        [("hexahedron", hexes)],
        point_data=point_data,
        cell_data={"labels": [image.ravel(order="F")], **{k: [v] for k, v in cell_data.items()}},
    )
    if kind == "xdmf":
        with meshio.xdmf.TimeSeriesWriter(path, data_format="XML") as writer:
            writer.write_points_cells(mesh.points, mesh.cells)
            writer.write_data(0.0, point_data=mesh.point_data, cell_data=mesh.cell_data)
    else:
        meshio.vtu.write(path, mesh)
    return path


def export_time_series(
    path: str | Path,
    labels: npt.ArrayLike,
    voxel_size: float | Sequence[float],
    times: npt.ArrayLike,
    fields: Mapping[str, npt.ArrayLike],
) -> Path:
    """Write nodal fields at several times to one ``.xdmf`` file (ParaView animates it).

    ``times`` has ``nt`` values (s); each field has shape ``(nt, n_nodes)`` (node order as in
    :func:`export_image`) or ``(nt, nx+1, ny+1, nz+1)``.

    >>> import tempfile, pathlib
    >>> file = export_time_series(pathlib.Path(tempfile.mkdtemp()) / "run.xdmf", np.zeros((1, 1, 1), int),
    ...                           1e-3, [0.0, 1.0], {"T": [np.zeros(8), np.ones(8)]})
    >>> with meshio.xdmf.TimeSeriesReader(file) as reader:
    ...     _ = reader.read_points_cells()
    ...     [float(reader.read_data(i)[0]) for i in range(reader.num_steps)]
    [0.0, 1.0]
    """
    path = Path(path)
    _format(path, {s: k for s, k in FORMATS.items() if k == "xdmf"})
    image = as_labels(labels, str(path))
    t = np.asarray(times, dtype=float).ravel()
    if t.size == 0 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InputError(f"{path}: times must be finite and strictly increasing, got {t.tolist()[:5]}…")
    series = {name: np.asarray(value, dtype=float) for name, value in fields.items()}
    for name, value in series.items():
        if value.shape[:1] != (t.size,):
            raise InputError(f"{path}: field {name!r} has {value.shape[:1]} time rows for {t.size} times")
    points, hexes = voxel_mesh(image.shape, voxel_size)
    with meshio.xdmf.TimeSeriesWriter(path, data_format="XML") as writer:
        writer.write_points_cells(points, [("hexahedron", hexes)])
        for step, time in enumerate(t):
            point_data, cell_data = _split_fields({n: v[step] for n, v in series.items()}, image.shape, path)
            cells = {"labels": [image.ravel(order="F")], **{k: [v] for k, v in cell_data.items()}}
            writer.write_data(float(time), point_data=point_data, cell_data=cells)
    return path
