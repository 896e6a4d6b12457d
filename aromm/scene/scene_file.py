"""Scene files (TOML, docs/design.md "Scene file"): load and validate into frozen objects.

Every refusal raises :class:`~aromm.core.errors.InputError` whose message names the file,
the key and what is allowed; the command line turns it into exit code 2.
"""

from __future__ import annotations

import inspect
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aromm.core.anisotropy import FIBRE_KEYS, phase_tensor
from aromm.core.errors import InputError
from aromm.core.labchecks import ABSOLUTE_ZERO
from aromm.core.resources import available_memory
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FACES, FaceSpec, Load, PhaseSpec, insulating, parameter_values, singular_boundary
from aromm.microstructure.generators import GENERATORS
from aromm.microstructure.segmentation import SegmentationReport, prepare_image
from aromm.physics.hygrothermal import MOISTURE_KEYS
from aromm.scene.contact_resistances import parse_interfaces
from aromm.scene.geometry import MESH_LABEL_KEY, MeshGeometry, SceneGeometry, VoxelGeometry
from aromm.scene.histories import history
from aromm.scene.model_section import parse_model, refusal, with_discretisation
from aromm.scene.moisture_section import FACE_KEYS as MOISTURE_FACE_KEYS
from aromm.scene.moisture_section import MoistureScene, parse_moisture
from aromm.scene.reduction_section import ReductionSettings, parse_reduction
from aromm.scene.sensors import Sensor, box, parse_sensors, scene_rows
from aromm.scene.time_section import AutoTime, auto_grid, parse_time
from aromm.scene.toml import TableReader, where

if TYPE_CHECKING:  # meshio (≈ 0.06 CPU s) is read for mesh scenes only
    import meshio

SECTIONS = ("geometry", "phases", "boundary", "initial", "time", "outputs", "interfaces", "source", "reduction",
            "model", "moisture")
PHASE_KEYS = ("label", "k", "c", *FIBRE_KEYS, *MOISTURE_KEYS)
FACE_KEYS = ("flux", "h", "T_ext", "T", *MOISTURE_FACE_KEYS)
IMAGE_KEYS = ("image", "voxel_size", "shape", "dtype", "segment", "crop", "downsample")
REFINE_BYTES_PER_VOXEL = 300.0  # memory of the multigrid homogenisation path (benchmarks/homogenize_peers.py)


@dataclass(frozen=True, eq=False)
class Scene:
    """A validated scene: a geometry (voxel image or conforming mesh), phases, face conditions, initial
    temperature, time grid, outputs (face means, and named sensors: aromm.scene.sensors), contact resistances
    (mesh scenes) and reduction settings."""

    geometry: SceneGeometry
    phases: tuple[PhaseSpec, ...]
    boundary: tuple[FaceSpec, ...] = ()
    initial_T: float = 0.0
    time: TimeGrid | None = None
    outputs: tuple[str, ...] = ()
    interfaces: Mapping[tuple[str, str], float] = field(default_factory=dict)
    path: Path | None = None
    reduction: ReductionSettings = field(default_factory=ReductionSettings)
    sensors: tuple[Sensor, ...] = ()
    segmentation: SegmentationReport | None = None  # a grey image's (aromm.microstructure.segmentation)
    discretisation: str = "q1"  # of a voxel image: "q1" elements or "fv" finite volumes (aromm.scene.model_section)
    moisture: MoistureScene | None = None  # coupled heat and moisture (aromm.scene.moisture_section)

    @property
    def parameters(self) -> dict[str, float]:
        """Named parameter values of this scene (``"fibre.k"``, ``"z1.h"``, ``"initial.T"``...)."""
        out = parameter_values(self.phases, self.boundary, self.initial_T, self.time is not None)
        return out if self.moisture is None else {**out, **self.moisture.parameters}

    @property
    def where(self) -> str:
        """Prefix naming the scene in messages: ``"<file>: "``, or ``"scene: "`` for one built in Python."""
        return where(self.path)

    @property
    def size(self) -> tuple[float, float, float]:
        """Edge lengths of the box (m): the voxel image, or the mesh's bounding box."""
        return self.geometry.size

    def volume_fractions(self) -> dict[str, float]:
        """Volume fraction of each phase (voxel counts, or the volumes of the mesh's cells)."""
        return self.geometry.volume_fractions(self.phases)

    def refined(self, factor: int, bytes_per_voxel: float = REFINE_BYTES_PER_VOXEL,
                budget: float | None = None) -> Scene:
        """The same scene with each voxel split into ``factor³`` sub-voxel elements.

        Labels are repeated ``factor`` times along each axis and ``voxel_size`` is divided by ``factor``: the
        geometry, the phases and the face conditions are unchanged, only the Q1 discretisation is finer
        (``aromm ... --refine R``).  Refused with :class:`InputError` when ``factor`` is not a positive
        integer, when the scene is a mesh, or when the refined problem's estimate
        ``factor³ · n_voxels · bytes_per_voxel`` exceeds ``budget`` (bytes; default: the memory available,
        :mod:`aromm.core.resources`).

        >>> phases = (PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, 2.0))
        >>> s = Scene(VoxelGeometry(np.arange(2).reshape(2, 1, 1), (2e-3, 1e-3, 1e-3)), phases)
        >>> r = s.refined(2)
        >>> r.geometry.labels[:, 0, 0].tolist(), r.geometry.voxel_size, r.size == s.size
        ([0, 0, 1, 1], (0.001, 0.0005, 0.0005), True)
        """
        if isinstance(factor, bool) or not isinstance(factor, int | np.integer) or factor < 1:
            raise InputError(f"{self.where}refine: the refinement factor must be a positive integer, got {factor!r}")
        if factor == 1:
            return self
        if not isinstance(self.geometry, VoxelGeometry):
            raise InputError(f"{self.where}refine: a mesh scene has no voxels to split; refine the mesh instead")
        labels, size = self.geometry.labels, self.geometry.voxel_size
        limit = (available_memory()[0] or np.inf) if budget is None else float(budget)
        need = float(labels.size) * factor**3 * bytes_per_voxel
        if need > limit:
            shape = "×".join(str(n * factor) for n in labels.shape)
            raise InputError(f"{self.where}refine: {factor}× gives {shape} voxels, about {need / 1e9:.3g} GB "
                             f"at {bytes_per_voxel:g} B/voxel, more than the {limit / 1e9:.3g} GB available")
        for axis in range(3):
            labels = np.repeat(labels, factor, axis=axis)
        voxel = (size[0] / factor, size[1] / factor, size[2] / factor)
        return replace(self, geometry=VoxelGeometry(labels, voxel))

    def with_boundary(self, boundary: tuple[FaceSpec, ...], outputs: tuple[str, ...],
                      time: TimeGrid | None = None) -> Scene:
        """The same material under other face conditions and face-mean outputs, without sensors (used by
        homogenisation and measurements)."""
        return replace(self, boundary=boundary, outputs=outputs, time=time, sensors=())


def assemble(scene: Scene, matrix_free: bool = False) -> ThermalSystem:
    """Assemble a scene into a :class:`ThermalSystem` holding only the effects it calls for.

    Voxel scenes: one Q1 hexahedron per voxel (aromm.fem.voxel); with ``matrix_free`` its terms are matrix-free
    operators (aromm.fem.voxel_terms; mesh scenes are assembled whatever it says).  Mesh scenes: Lagrange simplices with
    the interface conductance 1/R on split interface nodes (aromm.fem.mesh).  Sensors add their observation
    rows after the face means (aromm.scene.sensors).
    """
    singular = singular_boundary(scene.boundary, scene.time)
    if singular:
        raise InputError(f"{scene.where}{singular}")
    refused = refusal(scene.discretisation, scene.geometry, scene.phases)
    if refused is not None:
        raise InputError(f"{scene.where}{refused[0]}: {refused[1]}")
    voxels: dict[str, Any] = {"matrix_free": matrix_free, "discretisation": scene.discretisation}
    moisture = scene.moisture
    faces = scene.outputs if moisture is None else moisture.faces(scene.outputs)
    system = scene.geometry.assemble(scene.phases, scene.boundary, interfaces=scene.interfaces, time=scene.time,
                                     initial_T=scene.initial_T, outputs=faces, where=scene.where,
                                     **(voxels if isinstance(scene.geometry, VoxelGeometry) else {}))
    if scene.sensors:
        rows = scene_rows(scene, system, faces)
        system = replace(system, observation={**system.observation, **rows})
    return system if moisture is None else moisture.coupled(system, scene.outputs, scene.sensors)


def load_scene(path: str | Path, discretisation: str | None = None) -> Scene:
    """Read and validate a TOML scene file (docs/design.md).

    Paths inside the file are relative to the file.  Refused with :class:`InputError`:
    unknown sections, keys or faces; missing or unreadable images; phase labels absent
    from the image or image labels with no phase; non-positive or non-finite k or c;
    a face given two conditions; ``dt <= 0`` or ``end < dt``; non-3-D images; bad voxel_size.
    ``discretisation`` (``--discretisation``) replaces the file's ``[model] discretisation``.
    """
    path = Path(path)
    return scene_from_dict(with_discretisation(read_toml(path), discretisation), path)


def scene_files(path: str | Path) -> tuple[Path, ...]:
    """The scene file and the files it names (``geometry.image`` or ``mesh``, load histories of ``[boundary]``),
    relative paths taken from the scene's folder: the inputs a command must never overwrite."""
    path = Path(path)
    data = read_toml(path)
    geo, boundary = data.get("geometry", {}), data.get("boundary", {})
    named = [geo.get(k) for k in ("image", "mesh")] if isinstance(geo, dict) else []
    if isinstance(boundary, dict):
        named += [v for spec in boundary.values() if isinstance(spec, dict) for v in spec.values()]
    return (path, *(path.parent / v for v in named if isinstance(v, str)))


def read_toml(path: Path) -> dict[str, Any]:
    """The parsed scene file (not yet validated); InputError when missing or not TOML."""
    if not path.is_file():
        raise InputError(f"{path}: scene file not found")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: not a valid TOML file ({err})") from None


def scene_from_dict(data: Mapping[str, Any], path: Path | None = None, *,
                    image: tuple[np.ndarray, tuple[float, float, float] | None] | None = None) -> Scene:
    """Validate a scene given as a dict (the parsed TOML); ``path`` anchors relative paths.

    ``image`` = (labels, voxel size stored in the file or None) replaces reading ``geometry.image``: an
    engine that reads the image slab by slab passes a stand-in holding each label present once
    (aromm.engines.petsc.problem), so that the phases are checked without the whole image in memory.
    """
    r = TableReader(path)
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise r.fail(str(unknown[0]), f"unknown section; allowed: {', '.join(SECTIONS)}")
    geo = r.table(data, "geometry", None)
    report = None
    if "mesh" in geo:
        geometry: SceneGeometry = MeshGeometry(*_mesh(r, geo, path))
    else:
        labels, voxel, report = _geometry(r, geo, path, image)
        geometry = VoxelGeometry(labels, voxel)
    phases = _phases(r, data, geometry.present())
    from_image = [ph.name for ph in phases if ph.tensor is not None and ph.tensor.axes is None]
    if from_image and image is not None:
        raise r.fail(f"phases.{from_image[0]}.axis", "a fibre axis from the image needs the whole image: use the "
                                                     "scipy engine, or give the axis as [x, y, z]")
    boundary = _boundary(r, data)
    initial = r.table(data, "initial", ("T", "phi"))
    initial_T = _celsius(r, r.number(initial.get("T", 0.0), "initial.T"), "initial.T")
    time = parse_time(r, data)
    if time is not None and (cold := [ph.name for ph in phases if insulating(ph)]):
        raise r.fail(f"phases.{cold[0]}.k", "k = 0 (an insulating phase) is for steady scenes (no [time] section): "
                                             "a transient needs every phase to conduct")
    varying = [f.face for f in boundary if f.varies]
    if varying and time is None:
        raise r.fail(f"boundary.{varying[0]}", "a history (CSV file) needs a transient scene: add [time] end and dt")
    if time is not None:
        for ph in phases:
            if ph.c is None:
                raise r.fail(f"phases.{ph.name}.c", "a transient scene ([time]) needs every phase's capacity c")
    if isinstance(time, AutoTime):
        if image is not None:
            raise r.fail("time.end", '"auto" needs the whole image (its volume fractions): give end and dt in s, as '
                                     "a run on the scipy engine logs them")
        time = auto_grid(time, geometry.volume_fractions(phases), phases, boundary, geometry.size,
                               path=path)[0]
    outputs, sensors = _outputs(r, data, geometry)
    singular = singular_boundary(boundary, time)
    if singular and ("boundary" in data or outputs or sensors):  # without either, a material for `aromm homogenize`
        raise InputError(f"{where(path)}{singular}")
    interfaces = parse_interfaces(r, data, {ph.name for ph in phases})
    # the reduction may name capacities even in a material-only scene (a time grid is added later)
    moisture = parse_moisture(r, data, phases, np.subtract(*box(geometry)[::-1]))
    if moisture is not None and moisture.histories and time is None:
        raise r.fail("boundary", "a moisture history (CSV file) needs a transient scene: add [time] end and dt")
    allowed = parameter_values(phases, boundary, initial_T, transient=True)
    reduction = parse_reduction(r, data, allowed if moisture is None else {**allowed, **moisture.parameters})
    return Scene(geometry, phases, boundary, initial_T, time, outputs, interfaces, path, reduction, sensors, report,
                 parse_model(r, data, geometry, phases), moisture)


def _geometry(r: TableReader, geo: dict[str, Any], path: Path | None,
              image: tuple[np.ndarray, tuple[float, float, float] | None] | None = None,
              ) -> tuple[np.ndarray, tuple[float, float, float], SegmentationReport | None]:
    if not geo:
        raise r.fail("geometry", "missing: give image = \"file\" or generator = \"name\" with voxel_size")
    if ("image" in geo) == ("generator" in geo):
        raise r.fail("geometry", "give exactly one of image or generator")
    file_voxel: tuple[float, float, float] | None = None
    factor, report = 1, None
    if image is not None:
        if "image" in geo:  # the keys are checked as below; the file itself is read by the caller
            _input_file(r, geo, "image", IMAGE_KEYS, path)
            prepared = sorted(set(geo) & {"segment", "crop", "downsample"})
            if prepared:
                raise r.fail(f"geometry.{prepared[0]}", "a grey image, crop or down-sampling is read whole: use the "
                                                        "scipy engine, or save the prepared labels first")
        labels, vs = image
        file_voxel = _voxel_triple(r, vs, "geometry.image (voxel_size stored in the file)") if vs is not None else None
    elif "image" in geo:
        file = _input_file(r, geo, "image", IMAGE_KEYS, path)
        labels, vs, factor, report = prepare_image(file, geo, r.fail)
        file_voxel = _voxel_triple(r, vs, "geometry.image (voxel_size stored in the file)") if vs is not None else None
    else:
        name = geo["generator"]
        if name not in GENERATORS:
            raise r.fail("geometry.generator", f"unknown generator {name!r}; allowed: {', '.join(GENERATORS)}")
        generate = GENERATORS[name]
        options = {k: v for k, v in geo.items() if k not in ("generator", "voxel_size", "seed")}
        accepted = inspect.signature(generate).parameters
        if "voxel_size" in accepted and "voxel_size" in geo:
            options["voxel_size"] = geo["voxel_size"]
        if "rng" in accepted:
            seed = geo.get("seed", 0)
            if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
                raise r.fail("geometry.seed", f"must be a non-negative integer, got {seed!r}")
            options["rng"] = np.random.default_rng(seed)
        try:
            labels = generate(**options)
        except (TypeError, ValueError, MemoryError) as err:  # InputError is a ValueError: its own refusals
            raise r.fail("geometry", f"bad options for generator {name!r} (options: "
                                     f"{', '.join(k for k in accepted if k != 'rng')}): {err}") from None
    labels = np.asarray(labels)
    if labels.ndim != 3:
        raise r.fail("geometry.image", f"the image must be 3-D, got shape {labels.shape}")
    if "voxel_size" in geo:
        voxel = _voxel_triple(r, geo["voxel_size"], "geometry.voxel_size")
    elif file_voxel is not None:
        voxel = file_voxel
    else:
        raise r.fail("geometry.voxel_size", "missing: give the voxel edge in m, a number or [dx, dy, dz]")
    return labels, (voxel[0] * factor, voxel[1] * factor, voxel[2] * factor), report




def _input_file(r: TableReader, geo: dict[str, Any], key: str, allowed: tuple[str, ...], path: Path | None) -> Path:
    """The file named by ``geometry.<key>`` (relative to the scene file), after checking the other keys."""
    unknown = sorted(set(geo) - set(allowed))
    if unknown:
        raise r.fail(f"geometry.{unknown[0]}", f"unknown key with {key}; allowed: {', '.join(allowed)}")
    file = Path(str(geo[key]))
    if not file.is_absolute() and path is not None:
        file = path.parent / file
    if not file.exists():
        raise r.fail(f"geometry.{key}", f"file not found: {file}")
    return file


def _mesh(r: TableReader, geo: dict[str, Any], path: Path | None) -> tuple[meshio.Mesh, int]:
    """A conforming tetrahedral mesh (any format meshio reads; coordinates in m, phases by cell tag)."""
    import meshio

    file = _input_file(r, geo, "mesh", ("mesh", "order"), path)
    try:
        mesh = meshio.read(file)
    except (meshio.ReadError, ValueError, KeyError, OSError) as err:
        raise r.fail("geometry.mesh", f"cannot read {file} with meshio ({err})") from None
    if not any(block.type == "tetra" for block in mesh.cells):
        raise r.fail("geometry.mesh", f"{file} has no tetrahedra (cells: {sorted({b.type for b in mesh.cells})})")
    if MESH_LABEL_KEY not in mesh.cell_data:
        raise r.fail("geometry.mesh", f"{file} has no cell tags {MESH_LABEL_KEY!r} to tell the phases apart")
    order = geo.get("order", 1)
    if order not in (1, 2):
        raise r.fail("geometry.order", f"element order must be 1 or 2, got {order!r}")
    return mesh, int(order)


def _voxel_triple(r: TableReader, value: Any, key: str) -> tuple[float, float, float]:
    values = [value] * 3 if not isinstance(value, list | tuple | np.ndarray) else list(np.ravel(value))
    if len(values) != 3:
        raise r.fail(key, f"must be a number or three numbers [dx, dy, dz] in m, got {value!r}")
    dx, dy, dz = (r.number(v, key, positive=True, plausible="voxel_size") for v in values)
    return (dx, dy, dz)


def _phases(r: TableReader, data: Mapping[str, Any], present: set[int]) -> tuple[PhaseSpec, ...]:
    table = r.table(data, "phases", None)
    if not table:
        raise r.fail("phases", "missing: give at least one [phases.<name>] with label, k (and c)")
    sources = r.table(data, "source", None)
    phases = []
    for name in table:
        key = f"phases.{name}"
        spec = r.table(table, key, PHASE_KEYS, name)
        if "label" not in spec or isinstance(spec["label"], bool) or not isinstance(spec["label"], int):
            raise r.fail(f"{key}.label", "missing or not an integer image label")
        if spec["label"] not in present:
            raise r.fail(f"{key}.label", f"label {spec['label']} is absent from the image (labels: {sorted(present)})")
        try:
            tensor = phase_tensor(spec, key)
        except InputError as err:
            raise InputError(f"{where(r.path)}{err}") from None
        if "k" not in spec and tensor is None:
            raise r.fail(f"{key}.k", "missing conductivity in W/(m K) (or k_axial, k_transverse and axis of a fibre)")
        k_raw = spec.get("k")
        if tensor is not None:
            k: float | tuple[float, float, float] = max(tensor.values)
        elif isinstance(k_raw, list):
            if len(k_raw) != 3:
                raise r.fail(f"{key}.k", "orthotropic k must be [kx, ky, kz]")
            kx, ky, kz = (r.number(v, f"{key}.k", positive=True, plausible="k") for v in k_raw)
            k = (kx, ky, kz)
        elif (k := r.number(k_raw, f"{key}.k", plausible="k")) < 0:
            raise r.fail(f"{key}.k", f"must be >= 0 (0: an insulating phase, in a steady scene), got {k_raw!r}")
        c = r.number(spec["c"], f"{key}.c", positive=True, plausible="c") if "c" in spec else None
        q = None
        if name in sources:
            src = r.table(sources, f"source.{name}", ("q",), name)
            q = r.number(src.get("q"), f"source.{name}.q")
        phases.append(PhaseSpec(name, int(spec["label"]), k, c, q, tensor))
    unknown_sources = sorted(set(sources) - set(table))
    if unknown_sources:
        raise r.fail(f"source.{unknown_sources[0]}", f"no such phase; phases: {', '.join(table)}")
    missing = present - {p.label for p in phases}
    if missing:
        raise r.fail("phases", f"image labels {sorted(missing)} belong to no phase")
    if len({p.label for p in phases}) != len(phases):
        raise r.fail("phases", "two phases share one label")
    return tuple(phases)


def _boundary(r: TableReader, data: Mapping[str, Any]) -> tuple[FaceSpec, ...]:
    table = r.table(data, "boundary", None)
    faces = []
    for face in table:
        key = f"boundary.{face}"
        if face not in FACES:
            raise r.fail(key, f"unknown face; allowed: {', '.join(FACES)}")
        spec = r.table(table, key, FACE_KEYS, face)
        given = [k for k in ("flux", "h", "T") if k in spec]
        if "T" in spec and len(given) > 1:
            raise r.fail(key, f"a face takes one condition: a fixed T, or flux and/or h; got {given}")
        if "T_ext" in spec and "h" not in spec:
            raise r.fail(f"{key}.T_ext", "T_ext goes with h")
        faces.append(FaceSpec(
            face,
            flux=_load(r, spec["flux"], f"{key}.flux") if "flux" in spec else None,
            h=r.number(spec["h"], f"{key}.h", positive=True, plausible="h") if "h" in spec else None,
            T_ext=_load(r, spec.get("T_ext", 0.0), f"{key}.T_ext"),
            T=_load(r, spec["T"], f"{key}.T") if "T" in spec else None,
        ))
    return tuple(faces)


def _celsius(r: TableReader, value: float, key: str) -> float:
    """A scene temperature (°C), refused below absolute zero (a value in K, or a sign lost, is the usual cause)."""
    if value < ABSOLUTE_ZERO:
        raise r.fail(key, f"{value:g} °C is below absolute zero ({ABSOLUTE_ZERO:g} °C): scene temperatures are in °C")
    return value


def _load(r: TableReader, value: Any, key: str) -> Load:
    """A face value: a number, or a history file (:func:`aromm.scene.histories.history`): a fixed or exterior
    temperature in °C or K, a flux in W/m²."""
    if isinstance(value, str):
        return history(r, value, key, "flux" if key.endswith(".flux") else "temperature")
    number = r.number(value, key)
    return number if key.endswith(".flux") else _celsius(r, number, key)


def _outputs(r: TableReader, data: Mapping[str, Any],
             geometry: SceneGeometry) -> tuple[tuple[str, ...], tuple[Sensor, ...]]:
    """``mean_T`` (face means) and the named sensors ``[outputs.<name>]`` (aromm.scene.sensors)."""
    out = r.table(data, "outputs", None)
    faces = out.get("mean_T", [])
    if not isinstance(faces, list) or any(f not in FACES for f in faces):
        raise r.fail("outputs.mean_T", f"must be a list of faces among {', '.join(FACES)}, got {faces!r}")
    named = {k: v for k, v in out.items() if k not in ("mean_T", "mean_phi")}  # mean_phi: aromm.scene.moisture_section
    return tuple(faces), parse_sensors(named, box(geometry), faces, where(r.path),
                                       voxels=isinstance(geometry, VoxelGeometry))
