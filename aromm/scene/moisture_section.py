"""The scene's ``[moisture]`` vocabulary: coupled heat and moisture (:mod:`aromm.physics.hygrothermal`).

A scene without ``[moisture]`` is exactly a thermal scene; with it::

    [moisture]
    T_ref = 20.0          # °C, the linearisation's reference state
    phi_ref = 0.5
    latent_heat = 2.45e6  # J/kg, optional
    [phases.board]        # beside label, k and c, every phase: xi (kg/m³), D_phi (kg/(m s)), delta_p (kg/(m s Pa))
    xi = 20.0
    D_phi = 1.0e-9
    delta_p = 2.0e-11
    [boundary.x0]         # a fixed relative humidity (0–1) on a face
    phi = 0.8
    [boundary.x1]         # or vapour exchange with the air of a convective face; other faces are sealed
    h = 8.0
    T_ext = 20.0
    beta = 2.0e-8         # kg/(m² s Pa)
    phi_ext = 0.5
    [boundary.z1]         # or a moisture flux into the body (kg/(m² s)): rain, a wetting test
    g = 1.0e-6
    [initial]
    phi = 0.5             # default phi_ref
    [outputs]
    mean_phi = ["x1"]     # face-mean relative humidities; or a sensor's name ([outputs.<name>]): its φ

Parameters ``<phase>.xi``, ``<phase>.D_phi``, ``<phase>.delta_p``, ``<face>.phi``, ``<face>.beta``,
``<face>.phi_ext``, ``<face>.g`` and ``initial.phi`` join the scene's.  A phase may be orthotropic along the image
axes or a rotated tensor (a fibre axis; its D_phi and delta_p stay isotropic).  ``phi``, ``phi_ext`` and ``g`` may
be histories, as temperatures and heat fluxes are: the name of a CSV file ``t,<value>``
(:mod:`aromm.scene.histories`; a relative humidity as a fraction or in %RH, a moisture flux in kg/(m² s)), whose
parameter is then its scale, 1.  The petsc engine runs the full model (:mod:`aromm.engines.petsc.problem`: each rank
couples its box with :meth:`MoistureScene.part`); its reduced models of a coupled scene are not built yet.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from aromm.core.errors import InputError
from aromm.core.observables import PHI_PREFIX
from aromm.core.profiles import Profile
from aromm.core.system import ThermalSystem
from aromm.core.vocabulary import FACES, Load, PhaseSpec, scale_of
from aromm.physics.hygrothermal import LATENT_HEAT, MOISTURE_KEYS, MoistureState, coupled
from aromm.scene.histories import history
from aromm.scene.sensors import Sensor, output_names
from aromm.scene.toml import TableReader

STATE_KEYS = ("T_ref", "phi_ref", "latent_heat")
FACE_KEYS = ("phi", "beta", "phi_ext", "g")


@dataclass(frozen=True)
class MoistureScene:
    """The moisture part of a scene: the reference ``state``, each phase's ``xi``, ``D_phi`` and ``delta_p``, the
    faces with a ``fixed_phi``, ``initial_phi`` and the face-mean outputs ``outputs``."""

    state: MoistureState
    phases: Mapping[str, Mapping[str, float]]
    fixed_phi: Mapping[str, Load]
    initial_phi: float
    outputs: tuple[str, ...] = ()
    vapour: Mapping[str, tuple[float, Load]] = field(default_factory=dict)  # face → (beta, phi_ext)
    flux: Mapping[str, tuple[Load, float]] = field(default_factory=dict)  # face → (g kg/(m² s), its area m²)

    @property
    def boundary_values(self) -> dict[str, Load]:
        """The moisture boundary values by parameter name (``<face>.phi``, ``.phi_ext``, ``.g``): numbers or
        histories."""
        return {**{f"{face}.phi": v for face, v in self.fixed_phi.items()},
                **{f"{face}.phi_ext": v for face, (_, v) in self.vapour.items()},
                **{f"{face}.g": g for face, (g, _) in self.flux.items()}}

    @property
    def histories(self) -> dict[str, Profile]:
        """The boundary values that are histories, by parameter name (their parameter is the scale 1)."""
        return {name: v for name, v in self.boundary_values.items() if isinstance(v, Profile)}

    @property
    def parameters(self) -> dict[str, float]:
        """Its named parameter values (module docstring)."""
        out = {f"{phase}.{key}": float(v) for phase, values in self.phases.items() for key, v in values.items()}
        out.update({name: scale_of(v) for name, v in self.boundary_values.items()})
        out.update({f"{face}.beta": float(beta) for face, (beta, _) in self.vapour.items()})
        out["initial.phi"] = float(self.initial_phi)
        return out

    def faces(self, outputs: Sequence[str]) -> tuple[str, ...]:
        """The face outputs the thermal system must have: the scene's, then the faces of ``mean_phi`` and of the
        moisture fluxes (their face-mean rows carry the flux)."""
        extra = [f for f in (*self.outputs, *self.flux) if f in FACES and f not in outputs]
        return (*outputs, *dict.fromkeys(extra))

    def part(self, faces: Collection[str], phases: Collection[str]) -> MoistureScene:
        """The conditions of a part of the body (a rank's box of the image, on the petsc engine): those of the ``faces``
        of the whole box that it touches, and the properties of the ``phases`` it holds."""
        return replace(self, phases={k: v for k, v in self.phases.items() if k in phases},
                       fixed_phi={f: v for f, v in self.fixed_phi.items() if f in faces},
                       vapour={f: v for f, v in self.vapour.items() if f in faces},
                       flux={f: v for f, v in self.flux.items() if f in faces})

    def with_extent(self, extent: Sequence[float]) -> MoistureScene:
        """The same conditions on a box of edge lengths ``extent`` (m): each moisture flux's area is its face's
        (a scene read around a stand-in image, as the petsc engine reads it, is given its image's extent here)."""
        return replace(self, flux={f: (g, face_area(f, extent)) for f, (g, _) in self.flux.items()})

    def coupled(self, thermal: ThermalSystem, outputs: Sequence[str], sensors: Sequence[Sensor] = ()) -> ThermalSystem:
        """The coupled system of the scene's assembled ``thermal`` one, keeping the thermal face ``outputs`` and
        ``sensors``' outputs, and the ``phi:<name>`` of ``mean_phi``'s faces and sensors (a camera's: every pixel)."""
        system = coupled(thermal, self.state, self.phases, fixed_phi=self.fixed_phi, initial_phi=self.initial_phi,
                         vapour=self.vapour, moisture_flux=self.flux)
        humid = [*(f for f in self.outputs if f in FACES), *(o for s in sensors if s.name in self.outputs
                                                            for o in s.outputs)]
        wanted = {*outputs, *output_names(sensors), *(PHI_PREFIX + o for o in humid)}
        return replace(system, observation={k: v for k, v in system.observation.items() if k in wanted})


def parse_moisture(r: TableReader, data: Mapping[str, Any], phases: Sequence[PhaseSpec],
                   extent: Sequence[float]) -> MoistureScene | None:
    """The ``[moisture]`` part of a scene (None without the section; ``extent`` the box's edge lengths, m); the
    moisture keys of ``[phases]``, ``[boundary]``, ``[initial]`` and ``[outputs]`` are refused without it."""
    phase_tables = r.table(data, "phases", None)
    face_tables = r.table(data, "boundary", None)
    initial = r.table(data, "initial", None)
    outputs = r.table(data, "outputs", None)
    if "moisture" not in data:
        stray = [f"phases.{p}.{k}" for p, t in phase_tables.items() if isinstance(t, dict) for k in MOISTURE_KEYS
                 if k in t] + [f"boundary.{f}.{k}" for f, t in face_tables.items() if isinstance(t, dict)
                               for k in FACE_KEYS if k in t] + (["initial.phi"] if "phi" in initial else []) \
            + (["outputs.mean_phi"] if "mean_phi" in outputs else [])
        if stray:
            raise r.fail(stray[0], "a moisture key needs a [moisture] section (T_ref, phi_ref)")
        return None
    table = r.table(data, "moisture", STATE_KEYS)
    try:
        state = MoistureState(r.number(table.get("T_ref", 20.0), "moisture.T_ref"),
                              r.number(table.get("phi_ref", 0.5), "moisture.phi_ref"),
                              r.number(table.get("latent_heat", LATENT_HEAT), "moisture.latent_heat", positive=True))
    except InputError as err:
        raise InputError(f"{r.fail('moisture', str(err)).args[0]}") from None
    values: dict[str, dict[str, float]] = {}
    for ph in phases:
        spec = phase_tables.get(ph.name, {})
        missing = [k for k in MOISTURE_KEYS if k not in spec]
        if missing:
            raise r.fail(f"phases.{ph.name}.{missing[0]}", f"missing: a [moisture] scene needs every phase's "
                                                           f"{', '.join(MOISTURE_KEYS)}")
        values[ph.name] = {k: _non_negative(r, spec[k], f"phases.{ph.name}.{k}") for k in MOISTURE_KEYS}
    fixed, vapour, flux = {}, {}, {}
    for face, spec in face_tables.items():
        if not isinstance(spec, dict):
            continue
        if "g" in spec:
            if "phi" in spec or "beta" in spec:
                raise r.fail(f"boundary.{face}", "a face takes one moisture condition: phi, beta with phi_ext, or g")
            area = face_area(face, extent)
            g = spec["g"]
            key = f"boundary.{face}.g"
            flux[face] = (history(r, g, key, "moisture_flux") if isinstance(g, str) else r.number(g, key), area)
        if "phi" in spec:
            if "beta" in spec or "phi_ext" in spec:
                raise r.fail(f"boundary.{face}", "a face takes a fixed phi, or a vapour exchange beta with phi_ext")
            fixed[face] = _humidity_value(r, spec["phi"], f"boundary.{face}.phi")
        elif "beta" in spec or "phi_ext" in spec:
            if "beta" not in spec or "phi_ext" not in spec or "h" not in spec:
                raise r.fail(f"boundary.{face}", "a vapour exchange takes beta (kg/(m² s Pa)) and phi_ext, on a face "
                                                 "that exchanges heat with the same air (h, T_ext)")
            vapour[face] = (r.number(spec["beta"], f"boundary.{face}.beta", positive=True),
                            _humidity_value(r, spec["phi_ext"], f"boundary.{face}.phi_ext"))
    initial_phi = _humidity(r, initial.get("phi", state.phi_ref), "initial.phi")
    faces = outputs.get("mean_phi", [])
    sensors = [name for name, spec in outputs.items() if isinstance(spec, dict)]
    if not isinstance(faces, list) or any(f not in (*FACES, *sensors) for f in faces):
        raise r.fail("outputs.mean_phi", f"must be a list of faces among {', '.join(FACES)} or of the scene's sensors "
                                         f"({', '.join(sensors) or 'none'}), got {faces!r}")
    return MoistureScene(state, values, fixed, initial_phi, tuple(faces), vapour, flux)


def face_area(face: str, extent: Sequence[float]) -> float:
    """The area (m²) of ``face`` of a box of edge lengths ``extent`` (m).

    >>> face_area("z1", (2.0, 3.0, 5.0))
    6.0
    """
    axis = "xyz".index(face[0])
    return float(np.prod([e for a, e in enumerate(extent) if a != axis]))


def _non_negative(r: TableReader, value: Any, key: str) -> float:
    number = r.number(value, key)
    if number < 0:
        raise r.fail(key, f"must be >= 0, got {value!r}")
    return number


def _humidity(r: TableReader, value: Any, key: str) -> float:
    number = r.number(value, key)
    if not 0.0 <= number <= 1.0:
        raise r.fail(key, f"a relative humidity lies in [0, 1] (not %), got {value!r}")
    return number


def _humidity_value(r: TableReader, value: Any, key: str) -> Load:
    """A boundary relative humidity: a number in [0, 1], or a history file (fractions or %RH) within [0, 1]."""
    if not isinstance(value, str):
        return _humidity(r, value, key)
    profile = history(r, value, key, "humidity")
    if max(profile.values) > 1.0:
        raise r.fail(key, f"{profile.source}: a boundary relative humidity lies in [0, 1]; the history reaches "
                          f"{max(profile.values):g}")
    return profile


def split_outputs(payload: Mapping[str, Any]) -> dict[str, Any]:
    """A ``{"t", "mean_T"}`` JSON payload with the ``phi:<face>`` series moved to ``"mean_phi": {face: [...]}``
    (unchanged without any).

    >>> split_outputs({"t": [1.0], "mean_T": {"x1": [20.5], "phi:x1": [0.5]}})
    {'t': [1.0], 'mean_T': {'x1': [20.5]}, 'mean_phi': {'x1': [0.5]}}
    """
    series = payload.get("mean_T", {})
    phi = {k[len(PHI_PREFIX):]: v for k, v in series.items() if k.startswith(PHI_PREFIX)}
    if not phi:
        return dict(payload)
    return {**payload, "mean_T": {k: v for k, v in series.items() if not k.startswith(PHI_PREFIX)}, "mean_phi": phi}
