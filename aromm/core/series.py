"""Temperature fields for ParaView: one VTU file per time and a PVD collection that animates them.

The mesh is the system's own (:class:`aromm.core.system.Geometry`: the voxel hexahedra or the mesh's simplices, with
their cell data such as the phase labels); each VTU holds the nodal field ``T`` (°C) at one time (and ``phi``, the
relative humidity, for a coupled heat–moisture system), and
``<stem>.pvd`` lists them with their times (s)::

    <VTKFile type="Collection" version="0.1">
      <Collection>
        <DataSet timestep="0.5" part="0" file="field_0000.vtu"/>
        ...

Fields are written as they come (an iterator of ``(t, T)``), so a long series never has to be held in
memory.  Each file is written to a temporary name and renamed (a reader never sees half a file).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from aromm.core.errors import InputError
from aromm.core.files import atomic_path, atomic_write
from aromm.core.system import FloatArray, Geometry


def field_mesh(geometry: Geometry, field: FloatArray, names: tuple[str, ...] = ("T",)) -> meshio.Mesh:
    """The system's mesh with the nodal ``field`` as point data: one array per name of ``names``, the unknowns
    being one block of the nodes per name (a coupled system's ``("T", "phi")``).

    >>> geo = Geometry(np.eye(4, 3), np.array([[0, 1, 2, 3]]), "tetra")
    >>> sorted(field_mesh(geo, np.arange(8.0), ("T", "phi")).point_data["phi"].tolist())
    [4.0, 5.0, 6.0, 7.0]
    """
    values = np.asarray(field, dtype=float)
    if values.shape != (geometry.nodes * len(names),):
        raise InputError(f"a field has {values.size} values for {geometry.nodes} nodes and {len(names)} field(s)")
    blocks = values.reshape(len(names), geometry.nodes)
    return meshio.Mesh(geometry.points, [(geometry.cell_type, geometry.cells)],
                       point_data=dict(zip(names, blocks, strict=True)),
                       cell_data={k: [np.asarray(v)] for k, v in geometry.cell_data.items()})


def write_vtu(path: str | os.PathLike[str], geometry: Geometry, field: FloatArray,
              names: tuple[str, ...] = ("T",)) -> Path:
    """One field as a VTU file (zlib-compressed binary), written atomically."""
    with atomic_path(path, "field file") as tmp:
        meshio.vtu.write(tmp, field_mesh(geometry, field, names))
    return Path(path)


def series_file(folder: str | os.PathLike[str], step: int | None, stem: str = "field") -> Path:
    """The VTU file of the ``step``-th field of a series in ``folder`` (:func:`write_series`), or its PVD
    collection when ``step`` is None."""
    return Path(folder) / (f"{stem}.pvd" if step is None else f"{stem}_{step:04d}.vtu")


def write_series(folder: str | os.PathLike[str], geometry: Geometry, fields: Iterable[tuple[float, FloatArray]],
                 stem: str = "field", names: tuple[str, ...] = ("T",)) -> list[Path]:
    """``<stem>_0000.vtu``, ... (one per ``(t, T)`` of ``fields``, in order) and ``<stem>.pvd``; returns the paths.

    >>> import tempfile
    >>> geo = Geometry(np.eye(4, 3), np.array([[0, 1, 2, 3]]), "tetra")
    >>> paths = write_series(tempfile.mkdtemp(), geo, [(0.5, np.zeros(4)), (1.0, np.ones(4))])
    >>> [p.name for p in paths], float(meshio.read(paths[1]).point_data["T"][0])
    (['field_0000.vtu', 'field_0001.vtu', 'field.pvd'], 1.0)
    """
    out = Path(folder)
    written: list[Path] = []
    entries: list[str] = []
    previous = -np.inf
    for step, (t, field) in enumerate(fields):
        if not (np.isfinite(t) and t > previous):
            raise InputError(f"{out}: field times must be finite and increasing, got {t!r} after {previous!r}")
        previous = t
        path = write_vtu(series_file(out, step, stem), geometry, field, names)
        written.append(path)
        entries.append(f'    <DataSet timestep="{float(t)!r}" part="0" file={quoteattr(path.name)}/>')
    collection = series_file(out, None, stem)
    with atomic_write(collection, "ParaView collection") as fh:
        fh.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n')
        fh.write("".join(f"{e}\n" for e in entries))
        fh.write("  </Collection>\n</VTKFile>\n")
    return [*written, collection]
