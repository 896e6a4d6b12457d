"""ThermalSystem: the semi-discrete heat equation, affine in named parameters.

    C(p) dT/dt + K(p) T = F(p, t),     T(0) = T0(p),        T = T_D(p, t) on Dirichlet nodes,

with every operator an affine sum of fixed sparse matrices (or vectors) times scalar
coefficients of the parameters [Chavez2020, eq. 3, docs/design.md].  A load term or a fixed
temperature may also carry a known function of time g(t) (:class:`~aromm.core.profiles.Profile`, a
piecewise-linear history read from a CSV file): its contribution is ``c(p) g(t) F_j``, still affine
in the coefficients.  Parameters are named
``"<phase>.<property>"`` (``"fibre.k"``, ``"fibre.c"``, ``"fibre.k_x"``) or
``"<face>.<property>"`` (``"z1.h"``, ``"z0.flux"``, ``"x1.T"``); the uniform initial
temperature is ``"initial.T"``.

A coefficient is a product of parameters times a constant (``h * T_ext``), the
harmonic mean of two conductivities times a constant, possibly times further parameters (DEM bonds
between two phases, [Hassan2019, eq. 14]; finite-volume links), or one cone coordinate of the harmonic mean of
two phases' coupled heat–moisture flux matrices (:mod:`aromm.core.flux_cone`).  Reduced models keep the same
coefficients with projected matrices.

Units are SI: W/(m K), J/(m^3 K), W/m^2, W/(m^2 K), K (or degC: the equation is linear).
Only the terms a scene calls for are present: a steady system has ``capacity is None``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, cast

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.cache import content_key
from aromm.core.errors import InputError
from aromm.core.flux_cone import cone_harmonic
from aromm.core.profiles import Profile, time_factor

FloatArray = npt.NDArray[np.float64]
ParamValues = Mapping[str, npt.ArrayLike]



def dense(a: FloatArray | sp.csr_array) -> FloatArray:
    """``a`` as a dense float array: an observation row or matrix, which is sparse when it holds sensors."""
    if sp.issparse(a):
        return np.asarray(cast(Any, a).toarray(), dtype=float)
    return np.asarray(a, dtype=float)

@dataclass(frozen=True)
class Coefficient:
    """Scalar coefficient ``scale * prod(params)``, ``scale * 2 a b / (a + b) * prod(params[2:])`` (``"harmonic"``),
    or ``scale`` times one cone coordinate of the harmonic mean of two coupled flux matrices times
    ``prod(params[6:])`` (``"link"``: :func:`aromm.core.flux_cone.cone_harmonic` of ``weights * params[0:3]`` and
    ``weights * params[3:6]``, coordinate ``component``; the finite-volume links between two phases of the
    heat–moisture model).

    Called with parameter values it returns an array, so a whole swarm of parameter
    sets (arrays of equal length) is evaluated at once.
    """

    params: tuple[str, ...] = ()
    kind: Literal["product", "harmonic", "link"] = "product"
    scale: float = 1.0
    weights: tuple[float, ...] = ()  # "link": the three cone weights (x, y, z per parameter)
    component: int = 0  # "link": which cone coordinate (0 x, 1 y, 2 z)

    def __post_init__(self) -> None:
        if len(self.params) < self.special:
            raise ValueError(f"a {self.kind} coefficient takes at least {self.special} parameters")
        if self.kind == "link" and (len(self.weights) != 3 or self.component not in (0, 1, 2)):
            raise ValueError("a link coefficient takes three cone weights and a component 0, 1 or 2")

    @property
    def special(self) -> int:
        """How many leading parameters enter other than as factors (0, 2 for a harmonic mean, 6 for a link)."""
        return {"product": 0, "harmonic": 2, "link": 6}[self.kind]

    def __call__(self, values: ParamValues) -> FloatArray:
        try:
            args = [np.asarray(values[name], dtype=float) for name in self.params]
        except KeyError as err:
            raise InputError(
                f"parameter {err.args[0]!r} is needed by the system but was not given; "
                f"given: {sorted(values)}"
            ) from None
        head, rest = args[: self.special], args[self.special:]
        if self.kind == "harmonic":
            a, b = head
            out = np.asarray(self.scale * 2.0 * a * b / (a + b))
        elif self.kind == "link":
            w = self.weights
            cone = cone_harmonic((w[0] * head[0], w[1] * head[1], w[2] * head[2]),
                                 (w[0] * head[3], w[1] * head[4], w[2] * head[5]))
            out = np.asarray(self.scale * cone[self.component])
        else:
            out = np.asarray(self.scale, dtype=float)
        for c in rest:
            out = out * c
        return out

    def times(self, other: Coefficient) -> Coefficient:
        """The product of two coefficients (at most one not a product), e.g. ``fibre.k`` times ``x0.T``."""
        if self.kind != "product" and other.kind != "product":
            raise ValueError(f"the product of a {self.kind} and a {other.kind} coefficient is not a coefficient")
        first, second = (other, self) if other.kind != "product" else (self, other)
        return Coefficient((*first.params, *second.params), first.kind, self.scale * other.scale, first.weights,
                           first.component)

    def describe(self) -> str:
        """Readable form, e.g. ``2*fibre.k*gas.k/(fibre.k+gas.k)`` or ``z1.h*z1.T_ext``; a link names its cone
        coordinate, weights (to every digit: the form enters content hashes) and parameters."""
        head, rest = self.params[: self.special], self.params[self.special:]
        if self.kind == "harmonic":
            body = "*".join([f"2*{head[0]}*{head[1]}/({head[0]}+{head[1]})", *rest])
        elif self.kind == "link":
            w = ",".join(repr(float(x)) for x in self.weights)
            body = "*".join([f"link_{'xyz'[self.component]}[{w}]({','.join(head)})", *rest])
        else:
            body = "*".join(self.params) or "1"
        return body if self.scale == 1.0 else f"{self.scale:g}*{body}"


Role = Literal["capacity", "conduction", "exchange", "load", "initial", "output"]
ROLES: tuple[Role, ...] = ("capacity", "conduction", "exchange", "load", "initial", "output")


def is_matrix_free(operator: object) -> bool:
    """True for a matrix-free term operator (``@``, ``shape``, ``diagonal`` and ``tocsr``, e.g.
    aromm.fem.voxel_terms.VoxelTerm), false for sparse matrices and arrays."""
    return not sp.issparse(operator) and not isinstance(operator, np.ndarray) and hasattr(operator, "tocsr")


def sparse(operator: object) -> sp.csr_array:
    """A term's matrix as CSR; a matrix-free operator is assembled (small systems, code that needs a matrix)."""
    if is_matrix_free(operator):
        return sp.csr_array(operator.tocsr())  # type: ignore[attr-defined]
    return sp.csr_array(operator)


@dataclass(frozen=True)
class Term:
    """One named affine term: ``coefficient(p) * operator`` (a sparse or dense matrix, or a vector).

    ``role`` says what the term is physically: ``"capacity"`` (C, J/K), ``"conduction"`` inside the body
    (K with ``K 1 = 0``, W/K), ``"exchange"`` with the surroundings (convection, W/K), ``"load"`` (F, W),
    ``"initial"`` (a part of the initial field, K) or ``"output"`` (a part of the outputs, K).
    Reduction needs the distinction: the modal bases are built on the conduction terms only.
    ``time`` is a known function of time g(t) multiplying a load or output term (None: constant).
    """

    name: str
    coefficient: Coefficient
    operator: sp.csr_array | FloatArray
    role: Role
    time: Profile | None = None

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"unknown term role {self.role!r}; allowed: {', '.join(ROLES)}")


@dataclass(frozen=True)
class Affine:
    """An affine sum of terms; evaluates to a sparse matrix or a vector for one parameter set."""

    terms: tuple[Term, ...] = ()

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(t.name for t in self.terms)

    @property
    def parameters(self) -> frozenset[str]:
        return frozenset(p for t in self.terms for p in t.coefficient.params)

    @property
    def timed(self) -> bool:
        """True when a term carries a function of time."""
        return any(t.time is not None for t in self.terms)

    def _factors(self, at: float | None) -> FloatArray:
        if at is None:
            if self.timed:
                raise InputError(f"terms {[t.name for t in self.terms if t.time is not None]} vary in time: "
                                 "evaluate them at a time t")
            return np.ones(len(self.terms))
        return np.array([time_factor(t.time, at) for t in self.terms])

    def __bool__(self) -> bool:
        return bool(self.terms)

    def __getitem__(self, name: str) -> Term:
        for t in self.terms:
            if t.name == name:
                return t
        raise KeyError(f"no term {name!r}; terms are {self.names}")

    def with_role(self, *roles: Role) -> Affine:
        """The terms of the given roles only (e.g. the conduction terms, without the exchanges)."""
        return Affine(tuple(t for t in self.terms if t.role in roles))

    def coefficients(self, values: Mapping[str, FloatArray], m: int) -> FloatArray:
        """Coefficients of every term for m parameter sets (arrays of length m): shape (m, n_terms)."""
        return np.stack([np.broadcast_to(t.coefficient(values), (m,)) for t in self.terms], axis=1)

    def stack(self, values: Mapping[str, FloatArray], m: int, at: float | None = None) -> FloatArray:
        """``Σ_j c_j(p_i) g_j(at) A_j`` for m parameter sets at once, for dense operators:
        shape ``(m, *operator.shape)``.

        ``at`` (s) is needed when a term varies in time (``inf``: the held final values).
        """
        ops = np.stack([np.asarray(t.operator) for t in self.terms])
        return np.tensordot(self.coefficients(values, m) * self._factors(at), ops, axes=(1, 0))

    def evaluate(self, values: ParamValues, at: float | None = None) -> sp.csr_array | FloatArray:
        """Sum of ``coefficient * g(at) * operator`` for one parameter set (scalar values), as :meth:`stack`."""
        if not self.terms:
            raise ValueError("empty affine sum")
        factors = self._factors(at)
        total: sp.csr_array | FloatArray | None = None
        for t, g in zip(self.terms, factors, strict=True):
            part = float(t.coefficient(values)) * g * (sparse(t.operator) if is_matrix_free(t.operator) else t.operator)
            total = part if total is None else total + part
        assert total is not None
        return sp.csr_array(total) if sp.issparse(total) else np.asarray(total)


@dataclass(frozen=True)
class Dirichlet:
    """Fixed temperature ``values[param] * g(t)`` (K) on the nodes ``dofs`` (a face, or a set of particles);
    ``time`` is g (None: constant, g ≡ 1)."""

    name: str
    dofs: npt.NDArray[np.int64]
    param: str
    time: Profile | None = None


@dataclass(frozen=True)
class Geometry:
    """Where the unknowns sit, for export: points (n, 3) in m and cells of one meshio type."""

    points: FloatArray
    cells: npt.NDArray[np.int64]
    cell_type: str
    cell_data: Mapping[str, np.ndarray] = field(default_factory=dict)

    @property
    def nodes(self) -> int:
        """Number of points, without forming them where they are formed when read."""
        return int(self.points.shape[0])


@dataclass(frozen=True)
class TimeGrid:
    """Uniform output grid ``dt, 2 dt, ..., end`` (s)."""

    end: float
    dt: float

    @property
    def times(self) -> FloatArray:
        n = round(self.end / self.dt)
        return self.dt * np.arange(1, n + 1, dtype=float)


@dataclass(frozen=True)
class ThermalSystem:
    """``C(p) dT/dt + K(p) T = F(p, t)`` with observation rows ``E`` (face means).

    ``capacity`` is empty for a steady system; ``observation`` maps an output name
    (a face, or a sensor of aromm.scene.sensors) to a row vector ``e`` with ``e @ T`` the output (e.g. the face-mean
    temperature, so ``e`` sums to one); sensor rows are sparse (1, n) CSR arrays.  ``parameters`` holds the
    scene's values, which callers override by name.  ``boundary`` is the boundary mass ``B = ∫_Γ φ_a φ_b`` (m²)
    of the whole outer boundary Γ, attached by the assembler (the Steklov modes need it).

    Two optional groups serve systems derived from another one (the lifting of fixed temperatures,
    :mod:`aromm.reduction.lifting`): ``initial`` adds vectors (length n) to the uniform initial field,
    ``T(0) = initial.T + Σ c_i(p) v_i``, and ``feedthrough`` adds vectors over the outputs (length
    ``len(observation)``, in its order) to them, ``y = E T + Σ c_j(p) g_j(t) d_j``.  Assemblers leave both empty.

    ``fields`` names the nodal fields: the unknowns are ``len(fields)`` blocks of the geometry's nodes, in its order
    (the coupled heat–moisture model's ``("T", "phi")``, :mod:`aromm.physics.hygrothermal`).
    """

    n: int
    conductance: Affine
    capacity: Affine = Affine()
    load: Affine = Affine()
    dirichlet: tuple[Dirichlet, ...] = ()
    observation: Mapping[str, FloatArray | sp.csr_array] = field(default_factory=dict)
    parameters: Mapping[str, float] = field(default_factory=dict)
    time: TimeGrid | None = None
    geometry: Geometry | None = None
    boundary: sp.csr_array | None = None
    initial: Affine = Affine()
    feedthrough: Affine = Affine()
    fields: tuple[str, ...] = ("T",)

    @property
    def is_steady(self) -> bool:
        return not self.capacity

    def unknown_points(self) -> FloatArray | None:
        """Where every unknown sits (n, 3), m, for the nested-dissection orderings: the geometry's points, once per
        field; None without a geometry of the unknowns' nodes."""
        g = self.geometry
        if g is None or g.nodes * len(self.fields) != self.n:
            return None
        return g.points if len(self.fields) == 1 else np.tile(g.points, (len(self.fields), 1))

    @property
    def term_names(self) -> tuple[str, ...]:
        return self.capacity.names + self.conductance.names + self.load.names

    @property
    def parameter_names(self) -> frozenset[str]:
        names = (self.capacity.parameters | self.conductance.parameters | self.load.parameters
                 | self.initial.parameters | self.feedthrough.parameters)
        return names | {d.param for d in self.dirichlet} | {"initial.T"}

    def values(self, overrides: ParamValues | None = None) -> dict[str, npt.ArrayLike]:
        """The scene's parameter values updated by ``overrides``; unknown names are refused."""
        out: dict[str, npt.ArrayLike] = dict(self.parameters)
        out.setdefault("initial.T", 0.0)
        for name, value in (overrides or {}).items():
            if name not in self.parameter_names:
                raise InputError(
                    f"unknown parameter {name!r}; this system has {sorted(self.parameter_names)}"
                )
            out[name] = value
        return out

    def batch_values(self, params: ParamValues) -> tuple[dict[str, FloatArray], int]:
        """:meth:`values` for m parameter sets at once: arrays of equal length m → (dict of (m,) arrays, m).

        Unknown names, unequal lengths and non-finite values are refused with InputError.
        """
        arrays = {k: np.atleast_1d(np.asarray(v, dtype=float)).ravel() for k, v in params.items()}
        sizes = {a.size for a in arrays.values()}
        if len(sizes) > 1:
            raise InputError(f"parameter arrays must have equal lengths, got {sorted(sizes)}")
        m = sizes.pop() if sizes else 1
        out = {k: np.broadcast_to(np.asarray(v, dtype=float), (m,)) for k, v in self.values(arrays).items()}
        for k, v in out.items():
            if not np.all(np.isfinite(v)):
                raise InputError(f"parameter {k!r} has non-finite values")
        return out, m

    def fixed_owner(self) -> npt.NDArray[np.int64]:
        """Index into ``dirichlet`` of the set fixing each unknown (-1: free); the last set listing a node wins."""
        owner = np.full(self.n, -1, dtype=np.int64)
        for i, d in enumerate(self.dirichlet):
            owner[d.dofs] = i
        return owner

    def observation_matrix(self) -> tuple[tuple[str, ...], FloatArray | sp.csr_array]:
        """Output names and their rows stacked (n_outputs, n): dense, or CSR when a row is sparse (sensors)."""
        names = tuple(self.observation)
        if not names:
            return (), np.zeros((0, self.n))
        rows = [self.observation[k] for k in names]
        if any(sp.issparse(r) for r in rows):
            return names, sp.csr_array(sp.vstack([sp.csr_array(r.reshape(1, -1)) for r in rows]))
        return names, np.vstack(rows)

    def fingerprint(self) -> str:
        """Content hash of every term (name, role, coefficient, operator, time function), Dirichlet set and
        observation row."""
        def timing(g: Profile | None) -> tuple[object, ...]:  # empty for a constant term: hashes unchanged
            return () if g is None else (g.kind, g.arrays())

        return content_key(
            self.n,
            [(t.name, t.role, t.coefficient.describe(), t.operator, *timing(t.time))
             for group in (self.capacity, self.conductance, self.load, self.initial, self.feedthrough)
             for t in group.terms],
            [(d.name, d.param, d.dofs, *timing(d.time)) for d in self.dirichlet],
            [(name, row if sp.issparse(row) else np.asarray(row, dtype=float))
             for name, row in self.observation.items()],
            self.boundary,
        )[:20]


LIFT_FIRST = "must be lifted first (aromm.reduction.lifting.lift; aromm.reduce does it)"
PENALTY_INSTEAD = "are not supported (natural boundary conditions only); replace them by convection with a large h " \
                  "(penalty)"


def require_free_transient(system: ThermalSystem, purpose: str, remedy: str = LIFT_FIRST) -> None:
    """Refuse, with :class:`~aromm.core.errors.InputError`, a system that ``purpose`` cannot take: a steady one (the
    modal bases, the reduced model and the LTI export need the capacity ``C``), or one with fixed temperatures
    (they work on the free unknowns, natural boundary conditions only, [Chavez2020, eq. 5]); ``remedy`` says
    what to do about the fixed temperatures (:data:`LIFT_FIRST` or :data:`PENALTY_INSTEAD`).
    """
    if system.is_steady:
        raise InputError(f"{purpose} needs a transient system (a [time] section and phase capacities c)")
    if system.dirichlet:
        names = ", ".join(d.param for d in system.dirichlet)
        raise InputError(f"{purpose}: fixed temperatures ({names}) {remedy}")
