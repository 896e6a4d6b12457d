"""Danes-Garnier wall-insertion bounds of [GarnierDanes] for the simple-cubic (SC) cell.

A sphere of radius ``a`` in a ``2b x 2b x 2b`` cell, flux along z, contact resistance R_c
on the sphere; ``B = b/a - 1``, ``C = R_c lambda_m / a``, ``D = lambda_m / lambda_f``.

* Adiabatic walls parallel to the flux restrict the admissible heat fluxes: by Thomson's
  principle (which holds with the interface dissipation ``R_c int q_n^2``) they give
  **lower** bounds: ``W1a`` (one cylindrical wall r = a, :func:`wall_1a`) and ``W_inf_a``
  (infinitely many coaxial walls, closed form, :func:`wall_inf_a`).
* Isothermal surfaces across the flux restrict the admissible temperature fields: by
  Dirichlet's principle they give **upper** bounds: ``W1b`` (isothermal planes z = +-a,
  :func:`wall_1b`) and ``W_inf_b`` (every plane z = const isothermal within each phase,
  a singular ODE boundary-value problem, :func:`wall_inf_b`).

W1a and W1b need finite-element values of a sub-cell (``E_II``, ``E_1bot``): see
:mod:`aromm.bounds.cell_fem`.  The derivation of the W_inf_b system, and where the
transcription of [GarnierDanes] of it is inconsistent, are in ``docs/notes/wall_inf_b.md``.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.integrate import solve_bvp

from aromm.bounds.domain import check_B, check_contact, check_D, checked
from aromm.core.errors import NumericalError
from aromm.core.system import FloatArray

ArrayLike = npt.ArrayLike

# ---------------------------------------------------------------------------------------------
# Single walls: closed forms around the finite-element sub-cell values


def wall_1a(B: ArrayLike, E_II: ArrayLike) -> FloatArray:
    """W1a lower bound from the cylinder value: ``E = 1 + (pi/4) (E_II - 1)/(1 + B)^2`` [GarnierDanes].

    Parallel sum of the cylinder ``r < a`` (area ``pi a^2``, normalised conductance ``E_II``,
    adiabatic wall at r = a) and the pure matrix around it.
    """
    b = check_B(B)
    e = checked("E_II (cylinder conductance)", E_II, 0.0, low_open=True)
    return np.asarray(1.0 + 0.25 * np.pi * (e - 1.0) / (1.0 + b) ** 2)


def wall_1b(B: ArrayLike, E_1bot: ArrayLike) -> FloatArray:
    """W1b upper bound from the slab value: ``E = (B + 1)/(B + 1/E_1bot)`` [GarnierDanes].

    Series sum of the slab ``|z| < a`` holding the sphere (cell ``2b x 2b x 2a``, isothermal
    faces tangent to the sphere, normalised conductance ``E_1bot``) and two matrix slabs.
    """
    b = check_B(B)
    e = checked("E_1bot (slab conductance)", E_1bot, 0.0, low_open=True)
    return np.asarray((b + 1.0) / (b + 1.0 / e))


# ---------------------------------------------------------------------------------------------
# Infinitely many adiabatic walls (closed form)

_G_SERIES_RADIUS = 0.1
_G_SERIES_TERMS = 24  # 0.1**24/26 relative to the first term 0.1/3: < 1e-22


def _wall_bracket(eps: FloatArray) -> FloatArray:
    """``-(1/2 + 1/(1-G) + ln G/(1-G)^2)`` with ``eps = 1 - G``, i.e. ``sum_{k>=1} eps^k/(k+2)``.

    The closed form cancels like ``1e-16/eps^2`` as ``G -> 1``; for ``|eps| < 0.1`` the
    series (24 terms, Horner) is used, elsewhere ``log1p(-eps)``.
    """
    near = np.abs(eps) < _G_SERIES_RADIUS
    e_near = np.where(near, eps, 0.0)
    series = np.zeros_like(e_near)
    for k in range(_G_SERIES_TERMS, 0, -1):
        series = e_near * (1.0 / (k + 2.0) + series)
    e_far = np.where(near, 0.5, eps)
    with np.errstate(divide="ignore"):  # G = 0 (B = C = D = 0): log -> -inf, E -> +inf as the exact value
        closed = -(0.5 + 1.0 / e_far + np.log1p(-e_far) / (e_far * e_far))
    return np.asarray(np.where(near, series, closed))


def wall_inf_a(B: ArrayLike, C: ArrayLike, D: ArrayLike) -> FloatArray:
    """W_inf_a lower bound: infinitely many adiabatic walls parallel to the flux [GarnierDanes].

    ::

        E = 1 - pi/(2 (B+1)^2) [1/2 + 1/(1-G) + ln G/(1-G)^2],      G = (B + C + D)/(B + 1)
          = 1 + pi/(2 (B+1)^2) sum_{k>=1} (1-G)^k/(k+2)

    (effective_formulas.md §10: parallel sum of series slices, the interface crossed obliquely).
    Depends on C and D only through C + D; ``G = 1`` (neutral inclusion C + D = 1) gives
    exactly 1 and is evaluated by the series without 0/0; ``G = 0`` (B = C = D = 0) is +inf.
    """
    b, c, d = check_B(B), check_contact(C), check_D(D)
    g = (b + c + d) / (b + 1.0)
    return np.asarray(1.0 + np.pi / (2.0 * (b + 1.0) ** 2) * _wall_bracket(1.0 - g))


# ---------------------------------------------------------------------------------------------
# Infinitely many isothermal planes: perfect contact (closed form)


def _inv_artanh_ratio(x: FloatArray, one_minus_x: FloatArray) -> FloatArray:
    """``F(x) = int_0^1 dZ/(1 - x Z^2)``: artanh(sqrt x)/sqrt x (x > 0), arctan(sqrt -x)/sqrt -x (x < 0).

    ``1 - x`` is passed separately so that ``x -> 1`` keeps its digits; ``|x| < 1e-3`` uses the
    series ``sum x^k/(2k+1)``.
    """
    near = np.abs(x) < 1e-3
    xn = np.where(near, x, 0.0)
    series = np.zeros_like(xn)
    for k in range(8, -1, -1):
        series = 1.0 / (2 * k + 1) + xn * series
    xp = np.where(x >= 1e-3, x, 0.5)
    omx = np.where(x >= 1e-3, one_minus_x, 0.5)
    sq = np.sqrt(xp)
    positive = (np.log1p(sq) - 0.5 * np.log(omx)) / sq
    xm = np.sqrt(np.where(x <= -1e-3, -x, 0.5))
    negative = np.arctan(xm) / xm
    return np.asarray(np.where(near, series, np.where(x > 0.0, positive, negative)))


def wall_inf_b_perfect(B: ArrayLike, D: ArrayLike) -> FloatArray:
    """W_inf_b at C = 0: every plane z = const isothermal, i.e. slices in series.

    ``E = 1 / (4 (1+B) [F(x)/(alpha + beta) + B/alpha])`` with ``alpha = 4 (1+B)^2``,
    ``beta = pi (1/D - 1)``, ``x = beta/(alpha + beta)`` and ``F`` of
    :func:`_inv_artanh_ratio` (``int_0^b dz / (lambda_m A_m(z) + lambda_f A_f(z))``).
    ``D = 0`` gives ``(1 + B)/B`` (the sphere is isothermal); ``D = 1`` gives 1.
    """
    b, d = check_B(B), check_D(D)
    alpha = 4.0 * (1.0 + b) ** 2
    ds = np.where(d > 0.0, d, 1.0)  # D = 0 handled below: F/(alpha+beta) -> 0 like D ln(1/D)
    w = np.pi + ds * (alpha - np.pi)  # (alpha + beta) D > 0
    f = _inv_artanh_ratio(np.pi * (1.0 - ds) / w, alpha * ds / w)
    sphere = np.where(d > 0.0, ds * f / w, 0.0)
    with np.errstate(divide="ignore"):  # B = D = 0: touching isothermal spheres, +inf
        return np.asarray(1.0 / (4.0 * (1.0 + b) * (sphere + b / alpha)))


# ---------------------------------------------------------------------------------------------
# Infinitely many isothermal planes with contact resistance: singular BVP

# Below C = 1e-8 solve_bvp may stall (round-off in dJ/dZ = R/C keeps the collocation residual above tol:
# measured at C = 1e-10 for 5 of 15 (B, D), never at 1e-9 or 1e-8 on 100 random (B, D)).  Below the
# first floor, or when a direct solve stalls, E is interpolated in sqrt(C) from C = 0 to the smallest
# floor >= C that solves.
_C_FLOORS = (1e-10, 1e-9, 1e-8)
# 14 times the most solve_bvp used on 150 random (B, C >= 1e-9, D) (3640 nodes): a stalled solve stops sooner
_MAX_NODES = 50_000
# default relative collocation tolerance of solve_bvp; the error it leaves in E is below BVP_TOL * E
# (measured <= 0.54 BVP_TOL against tol = 1e-10 solves, tests/test_effective_wall.py)
BVP_TOL = 1e-8


@dataclass(frozen=True)
class WallProfile:
    """Solution of the W_inf_b problem on ``0 <= Z <= 1`` (Z = z/a), temperatures scaled by the half-cell drop.

    ``T``, ``S``: matrix and filler temperatures; ``flux_m``, ``flux_f``: their flux densities
    along -z in units of ``lambda_m (theta_b - theta_c)/a``; ``E`` the bound.
    """

    Z: FloatArray
    T: FloatArray
    S: FloatArray
    flux_m: FloatArray
    flux_f: FloatArray
    E: float


def _solve_profile(b: float, c: float, d: float, tol: float) -> WallProfile:
    """solve_bvp on x = 1 - Z with the singular term at x = 0 (Shampine 2003); see docs/notes/wall_inf_b.md.

    Unknowns ``y = (T, J, R, Q)``: matrix temperature, exchange flux ``J = (T - S)/C``, flux
    mismatch ``R = P - D Q`` and filler flux ``Q`` (``P = dT/dZ`` matrix flux).  This choice
    keeps every coefficient O(1) except ``dJ/dZ = R/C`` (no cancellation amplified by 1/C),
    and the singular matrix ``S`` has entries 0, +-1, +-D only.
    """
    am0 = 2.0 * (1.0 + b) ** 2 / np.pi
    sing = np.zeros((4, 4))
    sing[2] = [0.0, -d, 0.0, d]
    sing[3] = [0.0, 1.0, 0.0, -1.0]

    def rhs(x: FloatArray, y: FloatArray) -> FloatArray:
        _, j, r, q = y
        z = 1.0 - x
        am = am0 - 0.5 * x * (2.0 - x)
        p = r + d * q
        return np.vstack([-p, -r / c,
                          d * (z * q - j) / (2.0 - x) + (z * p - j) / am - d * q,
                          q - (z * q - j) / (2.0 - x)])

    def jac(x: FloatArray, y: FloatArray) -> FloatArray:
        out = np.zeros((4, 4, x.size))
        z = 1.0 - x
        am = am0 - 0.5 * x * (2.0 - x)
        out[0, 2] = -1.0
        out[0, 3] = -d
        out[1, 2] = -1.0 / c
        out[2, 1] = -d / (2.0 - x) - 1.0 / am
        out[2, 2] = z / am
        out[2, 3] = d * z / (2.0 - x) + d * z / am - d
        out[3, 1] = 1.0 / (2.0 - x)
        out[3, 3] = 1.0 - z / (2.0 - x)
        return out

    def bc(ya: FloatArray, yb: FloatArray) -> FloatArray:
        return np.array([ya[0] + b * (ya[2] + d * ya[3]) - 1.0, ya[3] - ya[1], yb[0], yb[1]])

    x0 = np.linspace(0.0, 1.0, 101)
    guess = np.zeros((4, x0.size))
    guess[0] = (1.0 - x0) / (1.0 + b)
    sol = solve_bvp(rhs, bc, x0, guess, fun_jac=jac, S=sing, tol=tol, max_nodes=_MAX_NODES)
    if sol.status != 0:
        raise NumericalError(f"W_inf_b: scipy solve_bvp failed for B={b:g}, C={c:g}, D={d:g}: {sol.message}")
    t, j, r, q = sol.y[:, ::-1]
    p = r + d * q
    e = (1.0 + b) * float(p[-1])
    return WallProfile(Z=1.0 - sol.x[::-1], T=t, S=t - c * j, flux_m=p, flux_f=q, E=e)


def wall_inf_b_profile(B: float, C: float, D: float, tol: float = BVP_TOL) -> WallProfile:
    """Temperature and flux profiles of W_inf_b for one (B, C > 0, D) (for plots and checks)."""
    b = float(check_B(B))
    c = float(checked("C (contact resistance R_c lambda_m / a)", C, 0.0, low_open=True))
    d = float(check_D(D))
    return _solve_profile(b, c, d, tol)


def wall_inf_b(B: ArrayLike, C: ArrayLike, D: ArrayLike, tol: float = BVP_TOL) -> FloatArray:
    """W_inf_b upper bound: isothermal planes z = const in each phase, exchange through R_c [GarnierDanes].

    The Euler-Lagrange equations of Dirichlet's principle restricted to fields ``tau(z)`` in the
    matrix and ``sigma(z)`` in the filler, made dimensionless (docs/notes/wall_inf_b.md)::

        dT/dZ = P,   dS/dZ = D Q,
        A_m(Z) dP/dZ = -Z P + (T - S)/C,        A_m = 2 (1+B)^2/pi - (1 - Z^2)/2,
        ((1 - Z^2)/2) dQ/dZ = Z Q - (T - S)/C,
        T(0) = S(0) = 0,   T(1) + B P(1) = 1,   Q(1) = (T(1) - S(1))/C   (regularity at Z = 1),
        E = (1 + B) P(1)

    ([GarnierDanes]: ``U = T + B P``, ``V = T + B Q``).  Solved by ``scipy.integrate.solve_bvp`` with
    the singular term at Z = 1 (relative collocation tolerance ``tol``; agreement with an
    independent 1-D Galerkin solution is ~1e-9).  ``C = 0`` uses :func:`wall_inf_b_perfect`;
    ``0 < C < 1e-10``, or ``C < 1e-8`` where the solver stalls, interpolates in ``sqrt(C)``
    between ``C = 0`` and the smallest of 1e-10, 1e-9, 1e-8 at or above C that solves (the approach
    to C = 0 is like sqrt(C) for D = 0, linear in C otherwise).  The interpolation error, measured
    against direct solves, is proportional to the floor: from 1e-10, below 2e-9 relative for
    B >= 0.1 and up to 1.6e-5 near touching spheres (B = 1e-3, D = 0); from 1e-9, ten times more.
    ``D + C = 1`` gives exactly 1: the neutral-inclusion field belongs to the restricted class.
    """
    b, c, d = np.broadcast_arrays(check_B(B), check_contact(C), check_D(D))
    out = np.empty(b.shape)
    for idx in np.ndindex(b.shape):
        out[idx] = _wall_inf_b_one(float(b[idx]), float(c[idx]), float(d[idx]), tol)
    return out


def _wall_inf_b_one(b: float, c: float, d: float, tol: float) -> float:
    """E of W_inf_b for one (B, C, D): direct solve, or the sqrt(C) interpolation of :func:`wall_inf_b`."""
    if c >= _C_FLOORS[-1]:
        return _solve_profile(b, c, d, tol).E
    e0 = float(wall_inf_b_perfect(b, d))
    if c == 0.0 or not np.isfinite(e0):
        return e0
    if c >= _C_FLOORS[0]:
        with contextlib.suppress(NumericalError):
            return _solve_profile(b, c, d, tol).E

    def interpolated(floor: float) -> float:
        return e0 + (_solve_profile(b, floor, d, tol).E - e0) * float(np.sqrt(c / floor))

    floors = [f for f in _C_FLOORS if f > c]
    for floor in floors[:-1]:
        with contextlib.suppress(NumericalError):
            return interpolated(floor)
    return interpolated(floors[-1])
