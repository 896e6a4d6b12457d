"""Coupled heat and moisture, linearised about a reference state, as an affine system of the thermal kind.

Fields T (°C) and φ (relative humidity, 0–1); per phase k (W/(m K)), c (J/(m³ K)), ξ = dw/dφ (kg/m³), D_φ
(kg/(m s), liquid and bound water on ∇φ) and δ_p (kg/(m s Pa), vapour permeability) [Kuenzel1995, § 2]:

    c ∂T/∂t = ∇·(k ∇T) + L_v ∇·(δ_p ∇p_v),     ξ ∂φ/∂t = ∇·(D_φ ∇φ) + ∇·(δ_p ∇p_v),

with the vapour pressure ``p_v = φ p_sat(T)`` linearised at (T_ref, φ_ref): ``∇p_v ≈ p ∇φ + a ∇T``,
``p = p_sat(T_ref)``, ``a = φ_ref p_sat′(T_ref)``, ``p_sat(T) = 610.5 exp(17.269 T / (237.3 + T))`` Pa [Tetens1930].
The moisture equation times ``λ = L_v p / a`` (J/kg) makes the 2 × 2 flux matrix symmetric:

    [[k + L_v δ_p a, L_v δ_p p], [L_v δ_p p, λ (D_φ + δ_p p)]]  =  k E_T + λ D_φ E_φ + δ_p (L_v / a) v vᵀ,

``E_T = diag(1, 0)``, ``E_φ = diag(0, 1)``, ``v = (a, p)``: each term positive semi-definite, the sum definite where
k > 0 and D_φ > 0; the capacity is ``diag(c, λ ξ)``.  So on 2n unknowns (the T block, then the φ block) the coupled
operators are affine in the phase parameters, each term ``B ⊗ K_i`` (K_i the thermal system's own conduction
operator of phase i, B one of the 2 × 2 blocks above) symmetric positive semi-definite, and every solver, reductor,
certificate and identification of the thermal model applies unchanged (docs/notes/hygrothermal.md).  L_v, T_ref and
φ_ref are constants of the model, not parameters (a product such as L_v δ_p would not be affine).

A finite-volume link between two phases carries the harmonic mean of their two flux matrices (the series of its
half cells), which no 2 × 2 block times a phase parameter reproduces; it stays in the cone of the flux matrices, so it
becomes three positive semi-definite terms with nonlinear coefficients ≥ 0 (:mod:`aromm.core.flux_cone`): the system
is still affine in the sense the solvers, reductors and the certificate need.

Boundary conditions here: the thermal system's own (fixed temperatures, flux, convection: T block only), fixed
relative humidities on faces (``fixed_phi``), vapour exchange with the air of a convective face (``vapour``: β and
φ_ext, the latent heat of the exchanged vapour included), a moisture flux (``moisture_flux``: g), and sealed faces
elsewhere (no moisture flux).  Outputs:
every thermal output on the T block, and ``phi:<output>`` the same row on the φ block.  Initial state: ``initial.T``
on T and ``initial.phi`` on φ (uniform).  Units SI except T in °C; the model is valid near (T_ref, φ_ref), where the
linearisation of p_v holds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from aromm.core.anisotropy import FIBRE_NAMES, TENSOR_NAMES
from aromm.core.errors import InputError
from aromm.core.observables import PHI_PREFIX
from aromm.core.profiles import Profile
from aromm.core.system import Affine, Coefficient, Dirichlet, FloatArray, Term, ThermalSystem, dense, sparse
from aromm.core.vocabulary import Load, scale_of

LATENT_HEAT = 2.45e6  # J/kg, evaporation of water near 20 °C
MOISTURE_KEYS = ("xi", "D_phi", "delta_p")


def p_sat(T: float) -> float:
    """Saturation vapour pressure (Pa) over water at T (°C) [Tetens1930].

    >>> round(p_sat(20.0))
    2337
    """
    return 610.5 * math.exp(17.269 * T / (237.3 + T))


def p_sat_slope(T: float) -> float:
    """dp_sat/dT (Pa/K) at T (°C)."""
    return p_sat(T) * 17.269 * 237.3 / (237.3 + T) ** 2


@dataclass(frozen=True)
class MoistureState:
    """The reference state of the linearisation: ``T_ref`` (°C), ``phi_ref`` (0–1), ``latent_heat`` L_v (J/kg)."""

    T_ref: float = 20.0
    phi_ref: float = 0.5
    latent_heat: float = LATENT_HEAT

    def __post_init__(self) -> None:
        if not 0.0 < self.phi_ref <= 1.0:
            raise InputError(f"moisture.phi_ref must lie in (0, 1], got {self.phi_ref!r}")
        if not self.latent_heat > 0.0:
            raise InputError(f"moisture.latent_heat must be positive (J/kg), got {self.latent_heat!r}")
        if not -50.0 <= self.T_ref <= 100.0:
            raise InputError(f"moisture.T_ref must lie in [-50, 100] °C (p_sat's range), got {self.T_ref!r}")

    @property
    def p(self) -> float:
        """p_sat(T_ref), Pa: ∂p_v/∂φ."""
        return p_sat(self.T_ref)

    @property
    def a(self) -> float:
        """φ_ref p_sat′(T_ref), Pa/K: ∂p_v/∂T."""
        return self.phi_ref * p_sat_slope(self.T_ref)

    @property
    def weight(self) -> float:
        """λ = L_v p / a (J/kg): the moisture equation's factor that makes the flux matrix symmetric."""
        return self.latent_heat * self.p / self.a

    def blocks(self) -> dict[str, FloatArray]:
        """The 2 × 2 blocks of each parameter's term (module docstring), by parameter suffix."""
        lam, a, p = self.weight, self.a, self.p
        return {"k": np.diag([1.0, 0.0]), "D_phi": np.diag([0.0, lam]),
                "delta_p": self.latent_heat / a * np.outer([a, p], [a, p]),
                "c": np.diag([1.0, 0.0]), "xi": np.diag([0.0, lam])}


def coupled(thermal: ThermalSystem, state: MoistureState, moisture: Mapping[str, Mapping[str, float]], *,
            fixed_phi: Mapping[str, Load] | None = None, initial_phi: float | None = None,
            vapour: Mapping[str, tuple[float, Load]] | None = None,
            moisture_flux: Mapping[str, tuple[Load, float]] | None = None) -> ThermalSystem:
    """The coupled system of the thermal system ``thermal`` (isotropic phases, orthotropic along the image axes, or
    rotated tensors; assembled or matrix-free terms, :func:`aromm.core.system.sparse`): ``moisture`` maps each phase
    name to its ``xi``, ``D_phi`` and ``delta_p``;
    ``fixed_phi`` maps faces (with a fixed temperature, or a face output) to a fixed relative humidity; the initial
    relative humidity is ``initial_phi`` (default φ_ref); ``vapour`` maps faces that exchange heat with the air (a
    convection ``h``) to ``(beta, phi_ext)``, their vapour exchange (:func:`_vapour_terms`); ``moisture_flux`` maps
    faces with a face-mean output of ``thermal`` to ``(g, area)``: g kg/(m² s) of water entering through the face of
    that area (m²), a load ``λ g |f| e_f`` on the moisture row (e_f the face-mean row; no latent heat: the water
    enters as it is stored).  Parameters ``<phase>.xi``, ``<phase>.D_phi``, ``<phase>.delta_p``, ``<face>.phi``,
    ``<face>.beta``, ``<face>.phi_ext``, ``<face>.g`` and ``initial.phi`` join the thermal ones.  A fixed φ, a
    φ_ext or a g may be a history (:class:`~aromm.core.profiles.Profile`): its parameter is then its scale, 1, and
    the profile is the Dirichlet value's or the load term's time function."""
    if thermal.initial or thermal.feedthrough:
        raise InputError("hygrothermal: couple the assembled thermal system, before any lifting")
    n, blocks = thermal.n, state.blocks()
    phases = _phases(thermal)
    missing = sorted(set(phases) - set(moisture))
    if missing:
        raise InputError(f"hygrothermal: no moisture properties for phase(s) {', '.join(missing)}; each phase needs "
                         f"{', '.join(MOISTURE_KEYS)}")
    parameters = dict(thermal.parameters)
    for name, values in moisture.items():
        if name not in phases:
            raise InputError(f"hygrothermal: unknown phase {name!r}; phases: {', '.join(sorted(phases))}")
        for key in MOISTURE_KEYS:
            value = values.get(key)
            if value is None or not math.isfinite(float(value)) or float(value) < 0.0:
                raise InputError(f"hygrothermal: {name}.{key} must be a finite value ≥ 0, got {value!r}")
            parameters[f"{name}.{key}"] = float(value)
    conductance, capacity = [], []
    for term in thermal.conductance.terms:
        op = sparse(term.operator)
        if term.role == "exchange":  # convection: the heat row only
            conductance.append(_block(term, term.name, term.coefficient, blocks["k"], op))
            continue
        pair = _phases_of_link(term)
        if pair is not None:
            conductance.extend(_link_terms(term, pair, state, op))
            continue
        phase = _phase_of(term)
        if phase is None:
            raise InputError(f"hygrothermal: the conduction term {term.name!r} ({term.coefficient.describe()}) is "
                             "not one phase's conductivity (k, its axis values, its tensor's or fibre's) nor a "
                             "finite-volume link between two phases")
        for key in ("k", "D_phi", "delta_p"):
            coefficient = term.coefficient if key == "k" else _renamed(term.coefficient, f"{phase}.{key}")
            conductance.append(_block(term, f"{term.name}_{key}", coefficient, blocks[key], op))
    for term in thermal.capacity.terms:
        phase = term.coefficient.params[0].rsplit(".", 1)[0]
        for key in ("c", "xi"):
            coefficient = term.coefficient if key == "c" else _renamed(term.coefficient, f"{phase}.xi")
            capacity.append(_block(term, f"{term.name}_{key}", coefficient, blocks[key], sparse(term.operator)))
    load = [Term(t.name, t.coefficient, np.concatenate([np.asarray(t.operator, dtype=float), np.zeros(n)]), t.role,
                 t.time) for t in thermal.load.terms]
    for face, (beta, phi_ext) in (vapour or {}).items():
        if not (math.isfinite(beta) and beta > 0.0 and _within(phi_ext, 0.0, 1.0)):
            raise InputError(f"hygrothermal: {face}.beta must be > 0 (kg/(m² s Pa)) and {face}.phi_ext in [0, 1], got "
                             f"{beta!r} and {phi_ext!r}")
        terms = _vapour_terms(thermal, face, state, _timing(phi_ext))
        conductance.append(terms[0])
        load.extend(terms[1:])
        parameters.update({f"{face}.beta": float(beta), f"{face}.phi_ext": scale_of(phi_ext)})
    for face, (g, area) in (moisture_flux or {}).items():
        row = thermal.observation.get(face)
        if row is None or not (_within(g, -math.inf, math.inf) and area > 0.0):
            raise InputError(f"hygrothermal: {face}.g needs a face-mean output of {face} and a finite flux "
                             f"(kg/(m² s)), got {g!r}")
        on_phi = np.concatenate([np.zeros(n), dense(row).ravel()])
        load.append(Term(f"G_{face}", Coefficient((f"{face}.g",), scale=state.weight * area), on_phi, "load",
                         _timing(g)))
        parameters[f"{face}.g"] = scale_of(g)
    dirichlet = list(thermal.dirichlet)
    for face, phi in (fixed_phi or {}).items():
        if not _within(phi, 0.0, 1.0):
            raise InputError(f"hygrothermal: {face}.phi must lie in [0, 1], got {phi!r}")
        dofs = _face_dofs(thermal, face)
        dirichlet.append(Dirichlet(f"{face}_phi", (dofs + n).astype(np.int64), f"{face}.phi", _timing(phi)))
        parameters[f"{face}.phi"] = scale_of(phi)
    parameters["initial.phi"] = state.phi_ref if initial_phi is None else float(initial_phi)
    on_phi = np.concatenate([np.zeros(n), np.ones(n)])
    initial = [Term("initial_phi", Coefficient(("initial.phi",)), on_phi, "initial"),
               Term("initial_T_off_phi", Coefficient(("initial.T",), scale=-1.0), on_phi, "initial")]
    observation: dict[str, FloatArray | sp.csr_array] = {}
    for name, row in thermal.observation.items():
        r = sp.csr_array(dense(row).reshape(1, -1))
        observation[name] = sp.csr_array(sp.hstack([r, sp.csr_array((1, n))]))
        observation[PHI_PREFIX + name] = sp.csr_array(sp.hstack([sp.csr_array((1, n)), r]))
    return ThermalSystem(2 * n, Affine(tuple(conductance)), Affine(tuple(capacity)), Affine(tuple(load)),
                         tuple(dirichlet), observation, parameters, thermal.time, thermal.geometry,
                         None if thermal.boundary is None else sp.csr_array(sp.block_diag([thermal.boundary] * 2)),
                         Affine(tuple(initial)), fields=("T", "phi"))


def _within(value: Load, low: float, high: float) -> bool:
    """Whether a boundary value (a number, or every value of a history) is finite and in [low, high]."""
    values = value.values if isinstance(value, Profile) else (value,)
    return all(math.isfinite(float(v)) and low <= float(v) <= high for v in values)


def _timing(value: Load) -> Profile | None:
    """The time function of a boundary value: its history, or None for a number."""
    return value if isinstance(value, Profile) else None


def _vapour_terms(thermal: ThermalSystem, face: str, state: MoistureState,
                  humidity: Profile | None = None) -> list[Term]:
    """The vapour exchange ``j = β (p_v,ext − p_v)`` (kg/(m² s)) through ``face``, with the outside air's
    ``p_v,ext`` linearised like ``p_v`` (``p_v,ext − p_v = p (φ_ext − φ) + a (T_ext − T)``, T_ext the face's
    convection temperature): it enters the moisture row (× λ) and, as latent heat L_v j, the heat row.  The operator
    ``β [[L_v a, L_v p], [λ a, λ p]] ⊗ M_f`` is β times the δ_p block (symmetric, as λ a = L_v p); the loads
    ``β (p φ_ext + a T_ext) (L_v, λ) ⊗ M_f 1``, φ_ext's with the time function ``humidity`` (None: constant).
    ``M_f`` is the face mass of the face's convection term."""
    exchange = next((t for t in thermal.conductance.terms if t.role == "exchange" and t.coefficient.params ==
                     (f"{face}.h",)), None)
    if exchange is None:
        raise InputError(f"hygrothermal: {face}.beta needs the face to exchange heat with the same air (an h and "
                         f"T_ext on {face})")
    mass = sparse(exchange.operator)
    ones = np.asarray(mass @ np.ones(mass.shape[0])).ravel()
    rows = np.concatenate([state.latent_heat * ones, state.weight * ones])
    heat = next(t for t in thermal.load.terms if t.coefficient.params == (f"{face}.h", f"{face}.T_ext"))
    block = state.latent_heat / state.a * np.outer([state.a, state.p], [state.a, state.p])
    return [Term(f"B_{face}", Coefficient((f"{face}.beta",)), sp.csr_array(sp.kron(block, mass)), "exchange"),
            Term(f"UB_{face}_phi", Coefficient((f"{face}.beta", f"{face}.phi_ext"), scale=state.p), rows, "load",
                 humidity),
            Term(f"UB_{face}_T", Coefficient((f"{face}.beta", f"{face}.T_ext"), scale=state.a), rows, "load",
                 heat.time)]


def _face_dofs(thermal: ThermalSystem, face: str) -> np.ndarray:
    """The unknowns of ``face``: those of its fixed temperature, else those its face-mean output weighs."""
    for d in thermal.dirichlet:
        if d.param == f"{face}.T":
            return np.asarray(d.dofs)
    row = thermal.observation.get(face)
    if row is None:
        raise InputError(f"hygrothermal: fixed_phi names {face!r}, neither a face with a fixed temperature nor an "
                         f"output face; outputs: {', '.join(thermal.observation)}")
    return np.flatnonzero(dense(row).ravel() != 0.0)


def _phases(thermal: ThermalSystem) -> set[str]:
    """The phases of the isotropic conduction terms (their parameter ``<phase>.k``)."""
    return {name for name in map(_phase_of, thermal.conductance.terms) if name is not None}


#: The conductivity parameters of one phase whose operators sum to the phase's isotropic one: ``k``; ``k_x``, ``k_y``,
#: ``k_z`` along the image axes; ``k_1``, ``k_2``, ``k_3`` of a tensor (Σ v_i v_iᵀ = I, orthonormal axes);
#: ``k_axial``, ``k_transverse`` of a fibre (a aᵀ + (I − a aᵀ) = I, per voxel for the image's axes)
#: [aromm.core.anisotropy].
CONDUCTIVITY_KEYS = ("k", "k_x", "k_y", "k_z", *TENSOR_NAMES, *FIBRE_NAMES)


def _phase_of(term: Term) -> str | None:
    """The phase of a conduction term whose coefficient is one of a phase's :data:`CONDUCTIVITY_KEYS`: its unit
    operators sum to the isotropic one, so D_φ and δ_p, isotropic, take each with the same coefficient; else None."""
    params = term.coefficient.params
    if term.role != "conduction" or term.coefficient.kind != "product" or len(params) != 1:
        return None
    return _conductivity_owner(params[0])


def _conductivity_owner(name: str) -> str | None:
    """The phase of a parameter named ``<phase>.<one of CONDUCTIVITY_KEYS>``, else None."""
    phase, _, key = name.rpartition(".")
    return phase if key in CONDUCTIVITY_KEYS and phase else None


def _phases_of_link(term: Term) -> tuple[str, str] | None:
    """The two phases of a finite-volume link term (a harmonic mean of two phases' conductivities), else None."""
    params = term.coefficient.params
    if term.role != "conduction" or term.coefficient.kind != "harmonic" or len(params) != 2:
        return None
    first, second = (_conductivity_owner(name) for name in params)
    return None if first is None or second is None else (first, second)


def _link_terms(term: Term, pair: tuple[str, str], state: MoistureState, op: sp.csr_array) -> list[Term]:
    """A link between two phases as three positive semi-definite terms: the cone coordinates of the harmonic mean of
    their 2 × 2 flux matrices (:mod:`aromm.core.flux_cone`) times ``S E_1 S``, ``S E_2 S`` and ``v vᵀ`` (``S = diag(a,
    p)``, ``v = (a, p)``) ⊗ the links' Laplacian; each phase's own conductivity name (k or k along the link's axis)
    is the thermal term's."""
    a, p = state.a, state.p
    weights = (1.0 / a**2, state.weight / p**2, state.latent_heat / a)
    params = tuple(name for k, phase in zip(term.coefficient.params, pair, strict=True)
                   for name in (k, f"{phase}.D_phi", f"{phase}.delta_p"))
    blocks = (np.diag([a * a, 0.0]), np.diag([0.0, p * p]), np.outer([a, p], [a, p]))
    return [_block(term, f"{term.name}_{'xyz'[c]}",
                   Coefficient(params, "link", term.coefficient.scale, weights, c), block, op)
            for c, block in enumerate(blocks)]


def _renamed(coefficient: Coefficient, name: str) -> Coefficient:
    """``coefficient`` with its (single) parameter replaced by ``name`` (the same scale)."""
    return Coefficient((name, *coefficient.params[1:]), coefficient.kind, coefficient.scale)


def _block(term: Term, name: str, coefficient: Coefficient, block: FloatArray, op: sp.csr_array) -> Term:
    return Term(name, coefficient, sp.csr_array(sp.kron(block, op)), term.role, term.time)
