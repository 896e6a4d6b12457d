"""The cache key of a reduced model, the same whichever engine builds it.

A reduced model is determined by the physics of its scene and by the reduction asked for; how the offline work
was done — the engine (``scipy`` on one process or ``petsc`` on any number of ranks and boxes), the linear
solver, the eigensolver, the storage of the basis — changes the model only within the tolerances of those
solvers (the engines agree to 1e-8 °C and better: docs/scaling.md), so none of it enters the key:

    key = SHA-256( physics(scene), order, reduction options other than :data:`HOW` ).

``physics`` is :func:`physics_key`: the image by a digest that does not depend on how it is cut into boxes
(:mod:`aromm.microstructure.digest`), the voxel size, phases, face conditions, initial temperature, time grid,
outputs and sensors, every number as a plain Python value (the same text under numpy 1 and 2).  A model built
by ``aromm reduce --engine petsc`` on a cluster is therefore found by ``aromm identify`` on a laptop given the
same cache folder, and the other way round (tests/test_model_key.py).  The key covers voxel scenes only; a
mesh scene or an assembled ThermalSystem keeps the engine's own key (:func:`aromm.api.reduce`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from aromm.core.cache import content_key
from aromm.microstructure.digest import label_digest
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

_VERSION = 1
#: Options of ``aromm.reduce`` that say how the model is computed, not which model: left out of the key.
HOW = frozenset({"engine", "solver", "eigensolver", "basis_storage", "cache", "progress", "eigen_progress",
                 "fields", "references"})


def plain(value: Any) -> Any:
    """``value`` as plain Python data for :func:`~aromm.core.cache.content_key`: dataclasses as (type name,
    fields), numpy scalars as Python numbers, sequences as tuples, mappings sorted by key; arrays kept (hashed
    by their bytes)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__name__,
                tuple((f.name, plain(getattr(value, f.name))) for f in dataclasses.fields(value)))
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return tuple((str(k), plain(value[k])) for k in sorted(value, key=str))
    if isinstance(value, list | tuple):
        return tuple(plain(v) for v in value)
    if isinstance(value, Path):
        return str(value)
    return value


def physics_key(digest: str, *, shape: Sequence[int], voxel_size: Sequence[float], phases: Any, boundary: Any,
                initial_T: float, time: Any, outputs: Sequence[str], sensors: Any = ()) -> str:
    """Content hash of a voxel scene's physics; ``digest`` the image's (:mod:`aromm.microstructure.digest`)."""
    return content_key("voxel physics", _VERSION, tuple(int(n) for n in shape), tuple(float(v) for v in voxel_size),
                       plain(phases), plain(boundary), float(initial_T), plain(time), tuple(str(o) for o in outputs),
                       plain(sensors), digest)


def scene_physics_key(scene: Scene) -> str | None:
    """:func:`physics_key` of a voxel scene read whole (None for a mesh scene or one with contact resistances)."""
    geometry = scene.geometry
    if not isinstance(geometry, VoxelGeometry) or scene.interfaces:
        return None
    return physics_key(label_digest(np.asarray(geometry.labels)), shape=geometry.shape,
                       voxel_size=geometry.voxel_size, phases=scene.phases, boundary=scene.boundary,
                       initial_T=scene.initial_T, time=scene.time, outputs=scene.outputs, sensors=scene.sensors)


def _empty(value: Any) -> bool:
    """An empty mapping or sequence: the same model as the option left out (its default)."""
    return isinstance(value, Mapping | list | tuple) and len(value) == 0


def model_key(physics: str, order: int, options: Mapping[str, Any], references: Sequence[str] = ()) -> str:
    """The key of the reduced model of order ``order`` of the scene of ``physics`` with the ``options`` of
    ``aromm.reduce`` (those in :data:`HOW`, None or empty left out; a reductor object by its ``cache_key`` or
    name) and the reference scenes of ``references`` (their physics keys)."""
    what = {name: getattr(v, "cache_key", getattr(v, "name", v)) if name == "method" and not isinstance(v, str)
            else v for name, v in options.items() if name not in HOW and v is not None and not _empty(v)}
    return content_key("reduced model", _VERSION, physics, int(order), plain(what), tuple(references))
