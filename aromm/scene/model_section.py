"""The ``[model]`` section of a scene: which discretisation turns the voxel image into a ThermalSystem.

``discretisation = "q1"`` (the default, the trilinear elements of [Chavez2020], :mod:`aromm.fem.voxel`) or ``"fv"``
(the cell-centred two-point finite volumes of taufactor and PuMA, :mod:`aromm.fv`); ``--discretisation`` on the
command line overrides it.  A phase with ``k = 0`` (insulating) needs a voxel image: ``fv`` removes the voxels it cuts
off; ``q1`` takes it where its system stays non-singular (:mod:`aromm.fem.insulation`, checked at assembly).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from aromm.core.choices import DISCRETISATIONS
from aromm.core.vocabulary import PhaseSpec, insulating
from aromm.scene.geometry import SceneGeometry, VoxelGeometry
from aromm.scene.toml import TableReader


def with_discretisation(data: Mapping[str, Any], discretisation: str | None) -> Mapping[str, Any]:
    """The parsed scene ``data`` with ``[model] discretisation`` replaced (``None``: unchanged)."""
    if discretisation is None:
        return data
    model = data.get("model", {})
    return {**data, "model": {**(model if isinstance(model, dict) else {}), "discretisation": discretisation}}


def refusal(name: str, geometry: SceneGeometry, phases: Sequence[PhaseSpec]) -> tuple[str, str] | None:
    """(key, why) when discretisation ``name`` cannot model this scene, else None: the one rule that the scene
    file, the assembly of a scene built in Python and ``identify --discretisation-check`` all apply."""
    if name not in DISCRETISATIONS:
        return "model.discretisation", (f"unknown discretisation {name!r}; allowed: q1 (trilinear elements, the "
                                        "default), fv (cell-centred finite volumes)")
    if name == "fv" and not isinstance(geometry, VoxelGeometry):
        return "model.discretisation", "fv discretises a voxel image; a mesh scene keeps its elements (q1)"
    cold = [ph.name for ph in phases if insulating(ph)]
    if cold and not isinstance(geometry, VoxelGeometry):
        return f"phases.{cold[0]}.k", "k = 0 (an insulating phase) is for voxel images"
    return None


def parse_model(r: TableReader, data: Mapping[str, Any], geometry: SceneGeometry,
                phases: Sequence[PhaseSpec]) -> str:
    """The scene's discretisation, checked against its geometry and phases (:func:`refusal`)."""
    name = r.table(data, "model", ("discretisation",)).get("discretisation", "q1")
    refused = refusal(str(name), geometry, phases)
    if refused is not None:
        raise r.fail(*refused)
    return str(name)
