"""A certified upper bound of a Galerkin reduced model's output error, in °C, per parameter point.

For ``C(μ) Ṫ + K(μ) T = Σ_j f_j(μ) g_j(t) F_j``, ``T(0) = T0(μ)`` (fixed temperatures lifted), outputs ``y = E T`` and
a Galerkin model on a basis Ψ (every term projected, ``Ψᵀ C Ψ X(0) = Ψᵀ C T0``), the Laplace transform of the output
error ``Δy = y − y_r`` is, for one output row e and any s off the negative real axis [Grepl2005, § 3; Antoulas2005,
ch. 11],

    Δŷ(s) = e_du(s)ᵀ r̂(s),   r̂ = b̂(s) − A(s) Ψ x̂(s),   r_du = eᵀ − A(s) Ψ ψ_r(s),   A(s) = K(μ) + s C(μ),

where x̂ and ψ_r are the reduced primal and dual solutions and e_du = A⁻¹ r_du the dual error (Galerkin orthogonality
Ψᵀ r̂ = 0 removes the reduced dual; A is complex symmetric).  On the sector ``|arg s| ≤ φ``, ``|v* A(s) v| ≥ cos(φ/2)
v*(K + |s| C) v`` for every v (K, C ≥ 0), so with the μ-independent norm ``N̂_σ = K(μ̂) + σ C(μ̂)`` and the min-θ
constant ``α(μ) = min_t θ_t(μ)/θ_t(μ̂)`` over the conductance and capacity terms with θ_t(μ̂) > 0 (exact and free:
every term's operator is positive semi-definite and every θ_t(μ) ≥ 0) [Haasdonk2008, § 4]::

    |Δŷ(s)| ≤ ‖r_du(s)‖_{N̂_σ⁻¹} ‖r̂(s)‖_{N̂_σ⁻¹} / (α(μ) cos(arg s / 2)),   any σ ≤ |s|.

The time-domain error follows from the Bromwich integral taken along a contour that wraps the origin and turns into
the left half-plane (a hyperbola, [Weideman2007]): ``|Δy(t_k)| ≤ (1/π) ∫ |Δŷ(s)| |e^{s t_k}| |ds|`` over the upper
half, and at the output times ``t_first ≤ t_k ≤ t_end`` the factor ``|e^{s t_k}| ≤ e^{Re s · t_first}`` on the arms
damps the high frequencies at which no reduced model is accurate (along a vertical line nothing damps them and the
integral overestimates the error by orders of magnitude; the bound's effectivities are measured by
benchmarks/certified_bound.py).  Load histories are piecewise linear:
each breakpoint's part enters with its own delay.  The dual norms come from one Gram matrix ``MᵀN̂_σ⁻¹M``,
``M = [U, Eᵀ, K_1Ψ, …, C_1Ψ, …]``, per σ of a geometric ladder over the contour's ``|s|`` (offline: one shifted solve
per column of M and rung); online every point costs reduced solves and quadratic forms, nothing of size n.

What the bound includes: the reduction error against the same semi-discrete full model solved exactly in time.  The
Gram matrices are corrected by the solves' residuals (:func:`riesz`: their error is second order in ``rtol``, and is
neglected); the worst-case rounding of those residuals (:func:`riesz`) and the rounding of the quadratic forms are
added.  The rounding of the n-term products ``MᵀZ`` is not bounded a priori (its worst case, ``n ε |M|ᵀ|Z|``, would
be the floor of every bound); two independent computations of the Gram matrices (multigrid and direct solves) differ
by at most 0.09 of the floor the bound adds (tests/test_certificate.py, benchmarks/gram_rounding.py).  It
neglects the contour's tail (``|e^{s t}| < e^{-40}`` there) and the quadrature error of the contour integral, which
is estimated from half the points and added.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from aromm.core.profiles import Profile
from aromm.core.system import FloatArray, ThermalSystem, dense
from aromm.reduction.modal_integration import diagonalise
from aromm.reduction.residual_form import ResidualForm

log = logging.getLogger(__name__)

#: The contour's arms leave the imaginary axis at this angle (rad): sector ``|arg s| ≤ π/2 + BETA``, inf-sup
#: cos(arg s / 2) ≥ 0.28 (a wider sector damps more and loses more in the inf-sup; not tuned).
BETA = 1.0
#: Contour points on the upper half (geometric in Im s); the half-grid estimate of the quadrature error is added.
POINTS = 600
#: ``|e^{s t}|`` below e^{-TAIL} on the contour's end: the rest of the arm is neglected.
TAIL = 40.0
#: Largest ratio of consecutive σ of the Gram ladder (between two rungs their Gram matrices are interpolated).
LADDER = 1000.0


class CertifyingEngine(Protocol):
    """What :func:`certify` needs of an engine (:class:`~aromm.reduction.scipy_engine.ScipyEngine` has it)."""

    def input_terms(self) -> Any: ...
    def output_block(self) -> Any: ...
    def term_products(self, basis: Any) -> Any: ...
    def join(self, blocks: Sequence[Any]) -> Any: ...
    def dot(self, left: Any, right: Any) -> FloatArray: ...
    def shifted_solve(self, values: Mapping[str, float], shift: float, rhs: Any, rtol: float,
                      guess: Any | None = None) -> Any: ...
    def shifted_residual(self, values: Mapping[str, float], shift: float, solution: Any, rhs: Any,
                         rtol: float) -> Any: ...
    def residual_rounding(self, values: Mapping[str, float], shift: float, solution: Any,
                          rtol: float) -> FloatArray: ...


@dataclass(frozen=True)
class Certificate:
    """Offline data of the bound (module docstring) for one model: ``theta`` the conductance-then-capacity terms'
    coefficients at the reference μ̂, ``sigmas`` the ladder (1/s), ``grams`` one ``MᵀN̂_σ⁻¹M`` per σ, ``vtu`` = ΨᵀU
    (r × p), ``loads`` the number of load columns of U (the initial-state columns follow).  The rounding floor of
    the quadratic forms takes the columns' norms from ``scales`` (per σ; default √diag of ``grams``) and counts
    ``summands`` terms in its sums (default the columns): a certificate whose Gram matrices were formed from a larger
    one's (:mod:`aromm.reduction.certificate_gram`) carries that one's.  ``spread`` (per σ and column, from
    :func:`riesz`) bounds the rounding of the solves' residuals, which enters the Gram matrices through ``RᵀZ``
    (None: a certificate cached before it was counted)."""

    theta: FloatArray
    sigmas: FloatArray
    grams: FloatArray
    vtu: FloatArray
    loads: int
    scales: FloatArray | None = None
    summands: int | None = None
    spread: FloatArray | None = None

    def __post_init__(self) -> None:  # every bound evaluation reads the Gram matrices by rows (residual_form)
        object.__setattr__(self, "grams", np.ascontiguousarray(self.grams))

    def arrays(self) -> dict[str, np.ndarray]:
        extra = {} if self.scales is None else {"scales": self.scales, "summands": np.array(self.summands)}
        if self.spread is not None:
            extra["spread"] = self.spread
        return {"theta": self.theta, "sigmas": self.sigmas, "grams": self.grams, "vtu": self.vtu,
                "loads": np.array(self.loads), **extra}

    @classmethod
    def from_arrays(cls, data: Mapping[str, np.ndarray]) -> Certificate:
        theta, sigmas, grams, vtu = (np.asarray(data[k], dtype=float) for k in ("theta", "sigmas", "grams", "vtu"))
        scales = np.asarray(data["scales"], dtype=float) if "scales" in data else None
        return cls(theta, sigmas, grams, vtu, int(data["loads"]), scales,
                   int(data["summands"]) if "summands" in data else None,
                   np.asarray(data["spread"], dtype=float) if "spread" in data else None)

    def floor_terms(self) -> tuple[FloatArray, int]:
        """The columns' norms per σ and the number of summands of the rounding floor (class docstring)."""
        scales = np.sqrt(np.maximum(np.diagonal(self.grams, axis1=1, axis2=2), 0.0)) if self.scales is None \
            else self.scales
        return scales, self.grams.shape[1] if self.summands is None else self.summands


def contour(end: float, first: float, gap: float | None = None) -> tuple[npt.NDArray[np.complex128], FloatArray]:
    """Points s (upper half, from the real axis) and trapezoid weights ``|ds|`` of the hyperbola
    ``s = 1/end − tan β (√(u² + y²) − y) + i u``, y = 1/first, out to where ``e^{Re s · gap} < e^{-TAIL}``."""
    gap = first if gap is None else gap
    y, slope = 1.0 / first, np.tan(BETA)
    top = y + (TAIL / gap + 1.0 / end) / slope
    u = np.concatenate([[0.0], np.geomspace(1e-3 / end, top, POINTS - 1)])
    s = 1.0 / end - slope * (np.sqrt(u ** 2 + y ** 2) - y) + 1j * u
    return s, _chords(s)


def ladder(end: float, first: float) -> FloatArray:
    """σ of the Gram matrices: geometric (ratio at most :data:`LADDER`, at least two) from the contour's smallest
    ``|s|`` (1/end) to its ``|s|`` where the zero-delay damping reaches e^{-TAIL}."""
    s, _ = contour(end, first)
    lo, hi = float(np.abs(s).min()), float(np.abs(s).max())
    count = max(2, int(np.ceil(np.log(hi / lo) / np.log(LADDER))) + 1)
    return np.geomspace(lo, hi, count)


def certify(engine: CertifyingEngine, system: ThermalSystem, basis: Any, reference: Mapping[str, float],
            rtol: float = 1e-10) -> Certificate:
    """The offline data of the bound for the model on ``basis`` (an engine block) of ``system`` (the engine's,
    lifted), normed at ``reference`` (μ̂, the box centre)."""
    assert system.time is not None
    start = time.process_time()
    products = engine.term_products(basis)
    u = engine.input_terms()
    m = engine.join([u, engine.output_block(), products])
    v = system.values(reference)
    theta = np.array([float(t.coefficient(v)) for t in (*system.conductance.terms, *system.capacity.terms)])
    sigmas = ladder(system.time.end, system.time.dt)
    grams, spread = [], []
    for sigma in sigmas:
        z, r, rho = riesz(engine, reference, float(sigma), m, rtol)
        g = engine.dot(m, z) + engine.dot(r, z)
        grams.append((g + g.T) / 2)
        spread.append(rho)
    log.info("certificate: %d Gram matrices of %d columns, %.1f CPU s", len(sigmas), grams[0].shape[0],
             time.process_time() - start)
    return Certificate(theta, sigmas, np.stack(grams), engine.dot(basis, u), len(system.load.terms),
                       spread=np.stack(spread))


def riesz(engine: CertifyingEngine, reference: Mapping[str, float], sigma: float, rhs: FloatArray,
          rtol: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``Z ≈ N̂_σ⁻¹ rhs`` solved to ``rtol``, its residual ``R = rhs − N̂_σ Z`` (``N̂_σ = K(μ̂) + σ C(μ̂)``, the
    engine's shifted operator at the reference) and the spread ρ of its rounding per column.

    R computed with machine epsilon u has ``|fl(R) − R| ≤ γ (|rhs| + |N̂||Z|) ≈ 2 (k + 1) u |N̂||Z|`` (k terms in a
    row of N̂, [Higham2002, § 3.5]), so the Gram entry ``RᵢᵀZⱼ`` moves by at most ``2 ε ρᵢ ρⱼ`` with
    ``ρᵢ² = (k + 1) (u / ε) |Zᵢ|ᵀ|N̂||Zᵢ|`` (Cauchy–Schwarz in ``|N̂|``, which is diagonally dominant, hence positive
    semi-definite; ε float64's); the quadratic forms of :func:`error_bound` add ``2 ε (|c|ᵀρ)²``.  ``|Z|ᵀ|N̂||Z|``
    exceeds ``ZᵀN̂Z`` = G_ii by the ratio of the operator's local to global stiffness (10⁵ at the smallest σ on a 12³
    body, growing as h⁻²): in float64 (u = ε) this term, not the quadratic forms, limited the Gram matrices, and
    its worst case raised the certified bound of the 46³ VER at eight greedy points from 1.9e-5 to 3.4e-5 °C
    (commit ca697a4).  The scipy engine forms R in extended precision
    (``np.longdouble``: u = ε / 2048 on x86-64), the petsc engine in float64 (its KSP's operator).

    The Gram matrix ``rhsᵀ N̂_σ⁻¹ rhs`` is then ``rhsᵀZ + RᵀZ`` up to ``RᵀN̂_σ⁻¹R``: the solves' error enters to
    second order.  Without ``RᵀZ`` it enters to first order, ``|RᵀZ|`` ≈ rtol √κ(N̂_σ) of the entries' scale: 1e-11
    with multigrid at rtol 1e-10 on a 12³ body, 100× the rounding floor of the quadratic forms
    (tests/test_certificate.py)."""
    z = np.asarray(engine.shifted_solve(reference, sigma, rhs, rtol))
    r = np.asarray(engine.shifted_residual(reference, sigma, z, rhs, rtol))
    return z, r, np.asarray(engine.residual_rounding(reference, sigma, z, rtol), dtype=float)


def _pieces(profile: Profile | None) -> list[tuple[float, float, int]]:
    """``ĝ(s) = Σ c e^{−sτ} / s^k`` of a load's time function as (c, τ, k): a constant is a step at 0."""
    if profile is None:
        return [(1.0, 0.0, 1)]
    t, g = np.asarray(profile.times, dtype=float), np.asarray(profile.values, dtype=float)
    if profile.kind == "steps":
        return [(float(d), float(ti), 1) for d, ti in zip(np.diff(np.concatenate([[0.0], g])), t, strict=True) if d]
    slopes = np.concatenate([[0.0], np.diff(g) / np.diff(t), [0.0]]) if t.size > 1 else np.zeros(2)
    out = [(float(g[0]), 0.0, 1)]
    out += [(float(d), float(ti), 2) for d, ti in zip(np.diff(slopes), t, strict=True) if d]
    return out


def _damping(s: npt.NDArray[np.complex128], delay: float, times: FloatArray) -> FloatArray:
    """max over output times t > delay of ``|e^{s (t − delay)}|`` (0 when none is later)."""
    later = times[times > delay * (1 + 1e-12)] - delay
    if later.size == 0:
        return np.zeros(s.shape)
    return np.where(s.real <= 0, np.exp(s.real * later.min()), np.exp(s.real * later.max()))


def error_bound(model: Any, cert: Certificate, values: Mapping[str, float]) -> FloatArray:
    """Upper bound (°C) of the largest ``|y_r − y|`` over the output times, per output, of ``model`` (a
    :class:`~aromm.reduction.rom.ReducedModel` carrying ``cert``) at ``values`` (module docstring); inf when a
    term's coefficient is negative there, or zero where the norm's is not."""
    sys_ = model.projected
    own = model.initial.parameters - sys_.parameter_names  # the model's initial terms' own (e.g. initial.phi)
    v = {**sys_.values({k: x for k, x in values.items() if k not in own}),
         **{k: x for k, x in values.items() if k in own}}  # any other unknown name is refused by values()
    terms = (*sys_.conductance.terms, *sys_.capacity.terms)
    theta = np.array([float(t.coefficient(v)) for t in terms])
    nk = len(sys_.conductance.terms)
    names, e = sys_.observation_matrix()
    rows = dense(e).reshape(len(names), -1)
    # terms absent from the norm (θ̂ = 0: e.g. a link's moisture coordinates next to a dry phase) only add coercivity
    normed = cert.theta > 0
    alpha = float(np.min(theta[normed] / cert.theta[normed])) if normed.any() else 0.0
    if np.any(theta < 0) or not alpha > 0 or sys_.time is None:
        return np.full(len(names), np.inf)
    times = sys_.time.times
    loads = sys_.load.terms
    pieces = [_pieces(t.time) for t in loads]
    initial = np.array([float(t.coefficient(v)) for t in model.initial.terms])
    if initial.size != cert.vtu.shape[1] - cert.loads:  # a model whose initial terms are not the certificate's,
        if cert.vtu.shape[1] > cert.loads or np.any(initial != 0):  # unless they vanish and it has none (a build
            return np.full(len(names), np.inf)  # at T0 = 0 that left them out: the petsc engine's)
        initial = initial[:0]
    gap = min([float(times[0])] + [float((times[times > tau] - tau).min()) for ps in pieces for _, tau, _ in ps
                                   if tau > 0 and np.any(times > tau)])
    s, w = contour(sys_.time.end, sys_.time.dt, gap)
    pencil = (np.asarray(sys_.capacity.evaluate(v))[None], np.asarray(sys_.conductance.evaluate(v))[None])
    rates, modes = diagonalise(*pencil)
    lam, vecs = rates[0], modes[0]
    r, p = cert.vtu.shape

    def solve(rhs: FloatArray) -> npt.NDArray[np.complex128]:  # (S, r): (K_r + s C_r)⁻¹ rhs for every s
        return (vecs @ ((vecs.T @ rhs)[None, :] / (lam[None, :] + s[:, None])).T).T

    # (K̂ + σĈ)⁻¹ ≤ θ N̂_a⁻¹ + (1 − θ) N̂_b⁻¹ for σ = θ σ_a + (1 − θ) σ_b (the inverse is operator convex), and
    # ≤ N̂_a⁻¹ for σ ≥ σ_a: between two rungs the two Gram matrices are interpolated, beyond them the nearest is used.
    sig = np.clip(np.abs(s), cert.sigmas[0], cert.sigmas[-1])
    lower = np.clip(np.searchsorted(cert.sigmas, sig, side="right") - 1, 0, len(cert.sigmas) - 1)
    upper = np.minimum(lower + 1, len(cert.sigmas) - 1)
    span = cert.sigmas[upper] - cert.sigmas[lower]
    share = np.where(span > 0, (cert.sigmas[upper] - sig) / np.where(span > 0, span, 1.0), 1.0)
    weights = np.array([np.where(lower == j, share, 0.0) + np.where((upper == j) & (upper != lower), 1 - share, 0.0)
                        for j in range(len(cert.sigmas))])
    diags, summands = cert.floor_terms()
    o = len(names)
    form = ResidualForm.of(cert.grams, scales=diags, spread=cert.spread, summands=summands, head=p + o, theta=theta,
                           conductances=nk)

    def norm(head: npt.NDArray[np.complex128], x: npt.NDArray[np.complex128]) -> FloatArray:
        return form.norm(s, head, x, weights)

    zero_head = np.zeros((s.size, p + o), dtype=complex)
    # zero-delay part of every input together (their errors may cancel: T0 = T_ext), each delayed piece alone
    head0, rhs0 = zero_head.copy(), np.zeros((s.size, r), dtype=complex)
    delayed = np.zeros(s.size)
    for j, (term, ps) in enumerate(zip(loads, pieces, strict=True)):
        scale = float(term.coefficient(v))
        for c, _, k in (piece for piece in ps if piece[1] == 0):
            g = scale * c / s ** k
            head0[:, j] += g
            rhs0 += g[:, None] * cert.vtu[:, j][None, :]
        late = [piece for piece in ps if piece[1] > 0]
        if late:
            unit_head = zero_head.copy()
            unit_head[:, j] = 1.0
            unit = norm(unit_head, solve(cert.vtu[:, j]))
            for c, tau, k in late:
                delayed += abs(scale * c) * unit * _damping(s, tau, times) / np.abs(s) ** k
    head0[:, cert.loads:p] += initial[None, :]
    rhs0 += (cert.vtu[:, cert.loads:] @ initial)[None, :]
    primal = norm(head0, _solve_rows(vecs, lam, s, rhs0)) * _damping(s, 0.0, times) + delayed
    kappa = np.cos(np.angle(s) / 2)
    coarse = np.zeros(s.size)
    coarse[::2] = _chords(s[::2])
    out = np.zeros(o)
    for i in range(o):
        head = zero_head.copy()
        head[:, p + i] = 1.0
        dual = norm(head, solve(rows[i]))
        integrand = dual * primal / (kappa * alpha)
        full = float(np.sum(w * integrand)) / np.pi
        half = float(np.sum(coarse * integrand)) / np.pi
        out[i] = full + abs(full - half)
    return out


def through_finer(model: Any, finer: Any, values: Mapping[str, float], own: FloatArray | None = None) -> FloatArray:
    """Upper bound (°C) of ``|y_r − y|`` per output over the output times through a finer certified model of the
    same full model: ``max_t |y_r − y_f| + bound_f`` (the triangle inequality; the difference is computed exactly in
    time, the finer model's bound by :func:`error_bound`).  Where the finer model's error is far below the model's,
    the difference is nearly the model's actual error: a model compressed from its span to a low order then has an
    effectivity near 1, where the direct bound's product of residual norms loses up to 10⁴ (a fixed-temperature
    face at order 12, docs/method/krylov.md).  ``own``: the finer model's bound at ``values`` when it is known
    already (a Krylov greedy's last evaluation over its training set, :class:`aromm.reduction.certified.SpanBound`)."""
    names = model.parameter_names
    # values of the initial terms' own parameters (e.g. initial.phi) other than the models' cannot be simulated
    other = any(k not in names and v != model.parameters.get(k, v) for k, v in values.items())
    own = finer.error_bound(values) if own is None else own
    if own is None or model.time is None or other:
        return np.full(len(model.outputs), np.inf)
    batch = {k: [v] for k, v in values.items() if k in names}
    times = model.time.times
    gap = np.abs(model.simulate_batch(batch, times)[0] - finer.simulate_batch(batch, times)[0]).max(axis=0)
    return np.asarray(gap + own, dtype=float)


def _solve_rows(vecs: FloatArray, lam: FloatArray, s: npt.NDArray[np.complex128],
                rhs: npt.NDArray[np.complex128]) -> npt.NDArray[np.complex128]:
    """Row k: (K_r + s_k C_r)⁻¹ rhs_k."""
    return ((rhs @ vecs) / (lam[None, :] + s[:, None])) @ vecs.T


def _chords(s: npt.NDArray[np.complex128]) -> FloatArray:
    """Trapezoid weights ``|ds|`` of a path through the points ``s``."""
    seg = np.abs(np.diff(s))
    return np.concatenate([seg, [0.0]]) / 2 + np.concatenate([[0.0], seg]) / 2
