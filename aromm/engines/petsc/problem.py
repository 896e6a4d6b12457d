"""A voxel scene whose image every rank reads box by box (memory-mapped .npy, TIFF pages, raw bytes).

:func:`load_problem` parses and validates the scene file as :func:`aromm.load_scene` does, but instead of
the whole image each rank opens the file's header (:class:`aromm.microstructure.boxes.ImageBoxes`), reads
its own box to find the labels present (their union over the ranks checks the phases), and keeps the file
open for the assembly; a ``.npz``, a TIFF not stored page by page or a generated image is first converted
once to a ``.npy`` by rank 0 (:mod:`aromm.engines.petsc.images`).  :meth:`VoxelProblem.from_scene` wraps a
scene already in memory.  The process grid is :func:`aromm.engines.petsc.layout.process_grid`'s unless the
PETSc options ``-aromm_da_processors_x/y/z`` fix some of its sizes (as PETSc's ``-da_processors_x``).

A scene with ``[moisture]`` (:mod:`aromm.physics.hygrothermal`) is coupled part by part: :meth:`VoxelProblem.part`
couples a rank's box with the serial :func:`aromm.physics.hygrothermal.coupled`, so the 2 × 2 blocks of every term
come from that module alone; the assembly interlaces the two fields (:mod:`aromm.engines.petsc.assembly`).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec, insulating
from aromm.engines.petsc import runtime
from aromm.engines.petsc.images import generated_image, open_image
from aromm.engines.petsc.layout import BoxLayout
from aromm.fem.voxel import assemble_voxels
from aromm.fv.volumes import assemble_volumes
from aromm.microstructure.boxes import ImageBoxes
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.model_section import with_discretisation
from aromm.scene.moisture_section import MoistureScene, face_area
from aromm.scene.scene_file import ReductionSettings, Scene, load_scene, read_toml, scene_from_dict

#: Named sensors ([outputs.<name>], aromm.scene.sensors) are observation rows of the serial assembly only.
SENSORS_REFUSED = "sensors are assembled by the scipy engine only; use --engine scipy (or mean_T outputs)"


@dataclass(frozen=True)
class VoxelProblem:
    """What the distributed assembler needs: the image by boxes, phases, faces, time grid and outputs."""

    image: ImageBoxes
    voxel_size: tuple[float, float, float]
    phases: tuple[PhaseSpec, ...]
    boundary: tuple[FaceSpec, ...]
    initial_T: float
    time: TimeGrid | None
    outputs: tuple[str, ...]
    present: tuple[int, ...]  # labels present in the whole image
    where: str = "scene: "
    reduction: ReductionSettings = field(default_factory=ReductionSettings)  # the scene's [reduction] values
    path: Path | None = None  # the scene file
    discretisation: str = "q1"  # "q1" elements (aromm.engines.petsc.assembly) or "fv" (volume_assembly)
    moisture: MoistureScene | None = None  # coupled heat and moisture (aromm.scene.moisture_section)

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.image.shape

    @property
    def size(self) -> tuple[float, float, float]:
        """Edge lengths of the box (m)."""
        return (self.shape[0] * self.voxel_size[0], self.shape[1] * self.voxel_size[1],
                self.shape[2] * self.voxel_size[2])

    @property
    def parameters(self) -> dict[str, float]:
        return dict(self.template().parameters)

    def layout(self, comm: Any) -> BoxLayout:
        return box_layout(self.shape, comm)

    def refuse_insulating(self) -> None:
        """Refuse an insulating phase (k = 0): fv removes the voxels it cuts off and q1 checks that it stays
        non-singular, both on the connectivity of the whole image, which the boxes do not compute."""
        cold = [ph.name for ph in self.phases if insulating(ph)]
        if cold:
            raise InputError(f"{self.where}phases.{cold[0]}: k = 0 (insulating) needs the connectivity of the whole "
                             "image, which the petsc engine does not compute; run it with --engine scipy")

    @property
    def fields(self) -> int:
        """Unknowns per node (or cell): 1, T; 2 with moisture, T and φ."""
        return 1 if self.moisture is None else 2

    @property
    def observed(self) -> tuple[str, ...]:
        """The face outputs of the thermal system: the scene's, and with moisture those of ``mean_phi`` and of the
        moisture fluxes (:meth:`aromm.scene.moisture_section.MoistureScene.faces`)."""
        return self.outputs if self.moisture is None else self.moisture.faces(self.outputs)

    def template(self) -> ThermalSystem:
        """The serial system of a stand-in image holding each present label once: the same terms (names,
        coefficients, order), parameters, Dirichlet faces and outputs as the whole image's system."""
        self.refuse_insulating()
        return self.part(np.asarray(self.present, dtype=np.int32).reshape(-1, 1, 1))

    def part(self, labels: np.ndarray, faces: Collection[str] | None = None) -> ThermalSystem:
        """The serial system of ``labels``, a part of the image (a rank's box) that touches the whole box's ``faces``
        (None: the whole box's faces, the stand-in of :meth:`template`): their conditions and face outputs, coupled
        with moisture by :meth:`MoistureScene.coupled`.  A part's face outputs are the whole face's mean restricted
        to it (``B_f 1 / |f|``, ``|f|`` the whole face's area), so that a moisture flux's load ``λ g |f| e_f`` is the
        part's share of the face's."""
        boundary = tuple(f for f in self.boundary if faces is None or f.face in faces)
        outputs = tuple(o for o in self.observed if faces is None or o in faces)
        assembler = assemble_volumes if self.discretisation == "fv" else assemble_voxels
        thermal = assembler(labels, self.voxel_size, self.phases, boundary, time=self.time,
                            initial_T=self.initial_T, outputs=outputs)
        if self.moisture is None:
            return thermal
        if faces is None:
            return self.moisture.coupled(thermal, self.outputs)
        extent = tuple(n * h for n, h in zip(labels.shape, self.voxel_size, strict=True))
        share = {f: face_area(f, extent) / face_area(f, self.size) for f in outputs}
        thermal = replace(thermal, observation={f: row * share[f] for f, row in thermal.observation.items()})
        present = {int(v) for v in np.unique(labels)}
        held = {ph.name for ph in self.phases if ph.label in present}
        return self.moisture.part(faces, held).coupled(thermal, ())

    def outline(self) -> Scene:
        """A Scene of this problem's box, phases, faces, time grid and outputs whose image is a zero-stride view of
        one label (no memory): what the command line's checks and the homogeneous twin
        (:func:`aromm.homogenization.properties.homogeneous_twin`) read.  Not the material: never assemble it."""
        labels = np.broadcast_to(np.int32(self.present[0] if self.present else 0), self.shape)
        return Scene(VoxelGeometry(labels, self.voxel_size), self.phases, self.boundary, self.initial_T, self.time,
                     self.outputs, path=self.path, reduction=self.reduction, moisture=self.moisture)

    def with_boundary(self, boundary: tuple[FaceSpec, ...], outputs: tuple[str, ...],
                      time: TimeGrid | None = None) -> VoxelProblem:
        """The same material under other face conditions (homogenisation probes)."""
        return replace(self, boundary=boundary, outputs=outputs, time=time)

    @classmethod
    def from_scene(cls, scene: Scene) -> VoxelProblem:
        geometry = scene.geometry
        if not isinstance(geometry, VoxelGeometry):
            raise InputError(f"{scene.where}the petsc engine assembles voxel images by boxes; for a mesh scene "
                             "assemble it (aromm.assemble) and pass the ThermalSystem, which is distributed by rows")
        if scene.interfaces:
            raise InputError(f"{scene.where}[interfaces]: contact resistance needs a conforming mesh")
        if scene.sensors:
            raise InputError(f"{scene.where}outputs.{scene.sensors[0].name}: {SENSORS_REFUSED}")
        present = tuple(sorted(geometry.present()))
        return cls(ImageBoxes.from_array(geometry.labels, scene.where.rstrip(": ") or "labels"),
                   geometry.voxel_size, scene.phases, scene.boundary, scene.initial_T, scene.time, scene.outputs,
                   present, scene.where, scene.reduction, scene.path, scene.discretisation, scene.moisture)


def box_layout(shape: tuple[int, int, int], comm: Any) -> BoxLayout:
    """This rank's box of an image of ``shape`` on the process grid (``-aromm_da_processors_x/y/z`` honoured)."""
    return BoxLayout.split(shape, runtime.size(comm), runtime.rank(comm), processors=runtime.processors())


def _generate(path: Path) -> np.ndarray:
    """The labels of a generated image (the whole scene validated and generated, on the rank that calls it)."""
    geometry = load_scene(path).geometry
    assert isinstance(geometry, VoxelGeometry)  # a generator makes a voxel geometry
    return geometry.labels


def load_problem(path: str | Path, comm: Any, discretisation: str | None = None) -> VoxelProblem:
    """Read a scene file for the petsc engine: every rank reads its box of the image (collective);
    ``discretisation`` (``--discretisation``) replaces the file's ``[model] discretisation``."""
    path = Path(path)
    data = with_discretisation(read_toml(path), discretisation)
    geo = data.get("geometry")
    outputs = data.get("outputs")
    named = [k for k in outputs if k not in ("mean_T", "mean_phi")] if isinstance(outputs, dict) else []
    if named:  # checked before the stand-in image, whose box is not the body's
        raise InputError(f"{path}: outputs.{named[0]}: {SENSORS_REFUSED}")
    if not isinstance(geo, dict) or ("image" in geo) == ("generator" in geo):
        return VoxelProblem.from_scene(load_scene(path, discretisation))  # a mesh, or the serial reader's errors
    if "generator" in geo:
        image = generated_image(path, geo, lambda: _generate(path), comm)
    else:
        file = Path(str(geo["image"]))
        if not file.is_absolute():
            file = path.parent / file
        if not file.exists():
            raise InputError(f"{path}: geometry.image: file not found: {file}")
        shape = geo.get("shape")
        image = open_image(file, tuple(int(n) for n in shape) if isinstance(shape, list | tuple) else None,
                           geo.get("dtype"), comm)
    present = sorted(runtime.union(image.labels_present(box_layout(image.shape, comm).box), comm))
    stand_in = np.asarray(present, dtype=np.int32).reshape(-1, 1, 1)
    scene = scene_from_dict(data, path, image=(stand_in, image.voxel_size))
    geometry = scene.geometry
    assert isinstance(geometry, VoxelGeometry)  # an image file is a voxel geometry
    extent = tuple(n * h for n, h in zip(image.shape, geometry.voxel_size, strict=True))
    moisture = None if scene.moisture is None else scene.moisture.with_extent(extent)  # read around the stand-in
    return VoxelProblem(image, geometry.voxel_size, scene.phases, scene.boundary, scene.initial_T, scene.time,
                        scene.outputs, tuple(present), scene.where, scene.reduction, path, scene.discretisation,
                        moisture)
