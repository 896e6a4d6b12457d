"""The cache key of a reduced model, the same whichever engine builds it.

A reduced model is determined by the physics of its scene and by the reduction asked for; how the offline work
was done — the engine (``scipy`` on one process or ``petsc`` on any number of ranks and boxes), the linear
solver, the eigensolver, the storage of the basis — changes the model only within the tolerances of those
solvers (the engines agree to 1e-8 °C and better: docs/scaling.md), so none of it enters the key:

    key = SHA-256( physics(scene), order, reduction options other than :data:`HOW` ).

``physics`` is :func:`physics_key`: the image by a digest that does not depend on how it is cut into boxes
(:mod:`aromm.microstructure.digest`), the voxel size, phases, face conditions, initial temperature, time grid,
outputs and sensors, the discretisation (q1 or fv), every number as a plain Python value (the same text under
numpy 1 and 2).  The values of
the parameters of the training box (the Krylov reduction's ``bounds``) are left out (:func:`masked`): the model is
trained over the box, so one model serves every value in it, and the loaded model takes the scene's own values
(:meth:`~aromm.reduction.rom.ReducedModel.with_parameters`); every value outside the box is in the key.

A system given assembled has no scene: :func:`system_key` keys it by the same rule, from its operators
(:meth:`~aromm.core.system.ThermalSystem.fingerprint`), the values of its parameters outside the box and its time
grid.  These are the only two keys of a reduced model: no cache below them (the Krylov and modal builds) keys a
model by anything less.  A model built
by ``aromm reduce --engine petsc`` on a cluster is therefore found by ``aromm identify`` on a laptop given the
same cache folder, and the other way round (tests/test_model_key.py).  The key covers voxel scenes only; a
mesh scene or an assembled ThermalSystem keeps the engine's own key (:func:`aromm.api.reduce`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from aromm.core.cache import content_key
from aromm.core.system import ThermalSystem
from aromm.microstructure.digest import label_digest
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

_VERSION = 7  # 2: box values masked, pinned values and time grid in every key; 3: models carry a certificate;
#  4: the discretisation (q1 or fv) in every voxel key; 5: modal models carry a certificate too; 6: certificates'
#  Gram matrices corrected by the solves' residuals (a cached model keeps the certificate it was built with);
#  7: models up to 200,000 unknowns certified by default (aromm.reduction.certified.CERTIFY_AFTER_BELOW)
#: What stands in a key for a value of the training box.
BOXED = "in the training box"
#: Options of ``aromm.reduce`` that say how the model is computed, not which model: left out of the key.
HOW = frozenset({"engine", "solver", "eigensolver", "basis_storage", "cache", "progress", "eigen_progress",
                 "fields", "references"})


def plain(value: Any) -> Any:
    """``value`` as plain Python data for :func:`~aromm.core.cache.content_key`: dataclasses as (type name,
    fields; a field outside the dataclass's equality, such as the file a history was read from, is left out: the
    same history from another file is the same load), numpy scalars as Python numbers, sequences as tuples, mappings
    sorted by key; arrays kept (hashed by their bytes)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__name__,
                tuple((f.name, plain(getattr(value, f.name))) for f in dataclasses.fields(value) if f.compare))
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return tuple((str(k), plain(value[k])) for k in sorted(value, key=str))
    if isinstance(value, list | tuple):
        return tuple(plain(v) for v in value)
    if isinstance(value, Path):
        return str(value)
    return value


def masked(specs: Any, box: Collection[str]) -> Any:
    """Phases (:class:`~aromm.core.vocabulary.PhaseSpec`) or faces (:class:`~aromm.core.vocabulary.FaceSpec`) as
    :func:`plain` data with every value of a parameter in ``box`` replaced by :data:`BOXED`.

    A phase's parameter ``<phase>.<field>`` is its field (``k``, ``c``, ``q``), ``<phase>.k_x`` a component of an
    orthotropic ``k``, ``<phase>.<name>`` a value of its tensor (whose ``k`` is then derived from the tensor and
    masked with it); a face's ``<face>.<field>`` is its number (a history keeps its whole profile in the key).

    >>> from aromm.core.vocabulary import PhaseSpec
    >>> masked([PhaseSpec("fibre", 1, 0.3, 4e6)], {"fibre.k"})[0][1][2:4]
    (('k', 'in the training box'), ('c', 4000000.0))
    """
    if isinstance(specs, str) or not all(dataclasses.is_dataclass(s) for s in specs):
        return plain(specs)  # not a scene's phases or faces: nothing to mask
    out = []
    for spec in specs:
        owner = getattr(spec, "name", None) or spec.face
        values = dict(plain(spec)[1])

        def hide(field: str, value: Any, owner: str = owner) -> Any:
            return BOXED if f"{owner}.{field}" in box and not isinstance(value, tuple | type(None)) else value

        tensor = getattr(spec, "tensor", None)
        if tensor is not None:
            names = tensor.names
            hidden = tuple(BOXED if f"{owner}.{n}" in box else float(v) for n, v in zip(names, tensor.values,
                                                                                         strict=True))
            values["tensor"] = (*[(k, v) for k, v in dict(plain(tensor)[1]).items() if k != "values"],
                                ("values", hidden))
            values["k"] = "derived from the tensor"
        elif isinstance(values.get("k"), tuple):
            values["k"] = tuple(BOXED if f"{owner}.k_{ax}" in box else v for ax, v in zip("xyz", values["k"],
                                                                                           strict=True))
        for field in ("k", "c", "q", "flux", "h", "T_ext", "T"):
            if field in values:
                values[field] = hide(field, values[field])
        out.append((type(spec).__name__, tuple(values.items())))
    return tuple(out)


def physics_key(digest: str, *, shape: Sequence[int], voxel_size: Sequence[float], phases: Any, boundary: Any,
                initial_T: float, time: Any, outputs: Sequence[str], sensors: Any = (),
                box: Collection[str] = (), discretisation: str = "q1", moisture: Any = None) -> str:
    """Content hash of a voxel scene's physics; ``digest`` the image's (:mod:`aromm.microstructure.digest`); the
    values of the parameters named in ``box`` left out (:func:`masked`); ``discretisation`` q1 or fv; ``moisture``
    the scene's moisture part as :func:`moisture_part` gives it (None: a thermal scene, the key of before)."""
    initial = BOXED if "initial.T" in box else float(initial_T)
    parts = () if moisture is None else (plain(moisture),)
    return content_key("voxel physics", _VERSION, tuple(int(n) for n in shape), tuple(float(v) for v in voxel_size),
                       masked(phases, box), masked(boundary, box), initial, plain(time),
                       tuple(str(o) for o in outputs), plain(sensors), digest, str(discretisation), *parts)


def scene_physics_key(scene: Scene, box: Collection[str] = ()) -> str | None:
    """:func:`physics_key` of a voxel scene read whole (None for a mesh scene or one with contact resistances)."""
    geometry = scene.geometry
    if not isinstance(geometry, VoxelGeometry) or scene.interfaces:
        return None
    return physics_key(label_digest(np.asarray(geometry.labels)), shape=geometry.shape,
                       voxel_size=geometry.voxel_size, phases=scene.phases, boundary=scene.boundary,
                       initial_T=scene.initial_T, time=scene.time, outputs=scene.outputs, sensors=scene.sensors,
                       box=box, discretisation=scene.discretisation,
                       moisture=None if scene.moisture is None else moisture_part(scene.moisture, box))


def moisture_part(moisture: Any, box: Collection[str]) -> tuple[Any, ...]:
    """A scene's moisture part (:class:`~aromm.scene.moisture_section.MoistureScene`) as key data: its reference
    state, its outputs, every parameter value, those in ``box`` replaced by :data:`BOXED`, and its boundary histories
    whole (their parameter is only their scale; a thermal face keeps its profile likewise, :func:`masked`)."""
    values = tuple(sorted((name, BOXED if name in box else value) for name, value in moisture.parameters.items()))
    histories = plain(moisture.histories)
    return ("moisture", plain(moisture.state), values, tuple(moisture.outputs), *((histories,) if histories else ()))


def system_key(system: ThermalSystem, box: Sequence[tuple[str, float, float]], *parts: Any,
               fingerprint: str | None = None) -> str:
    """The key of a reduced model of an assembled ``system`` trained over ``box`` ((name, lower, upper) per
    parameter), with ``parts`` (the reduction's options): its operators, outputs and histories (its fingerprint, or
    ``fingerprint`` when the operators live elsewhere, e.g. distributed), the box, the values of every parameter
    outside it (the initial temperature among them) and its time grid."""
    names = {name for name, _, _ in box}
    pinned = {k: float(np.asarray(v)) for k, v in system.values().items() if k not in names}
    return content_key("reduced system", _VERSION, fingerprint or system.fingerprint(), plain(pinned),
                       plain(system.time), plain(tuple(box)), plain(parts))


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
