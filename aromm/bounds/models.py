"""Closed-form effective-conductivity models and bounds [GarnierDanes] (checked: docs/notes/effective_formulas.md).

Every function is a plain vectorised numpy function returning ``E = lambda_eff / lambda_m``
(broadcasting its arguments).  Notation of [GarnierDanes]: ``kappa = lambda_f / lambda_m = 1/D``,
``phi`` the filler volume fraction, ``C = R_c lambda_m / a`` the dimensionless contact
(Kapitza) resistance of spheres of radius ``a``.

Removable singularities are written out of the formulas rather than caught:

* contrast -> 1 (``kappa = 1``, ``C = 0``): every model is evaluated in a form without
  ``1/(1 - kappa)`` (e.g. Hashin-Shtrikman particle bound); the two third-order bounds of
  Torquato & Rintoul have a genuine 0/0 only at ``D = 1, C = 0`` exactly, whose limit is the
  value of the regular part (the quotient tends to 0); it is assigned there, and nowhere else
  can the denominator vanish (it is a sum of non-negative terms, see the functions).
* aspect ratio -> 1 in the Hatta-Taya depolarisation factors: a Taylor series.

Inputs outside the physical domain raise :class:`~aromm.core.errors.InputError` naming the
argument and its allowed range.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.interpolate import PchipInterpolator

from aromm.bounds.domain import (
    PHI_MAX_SC,
    check_contact,
    check_kappa,
    check_phi,
    checked,
)
from aromm.core.errors import InputError
from aromm.core.system import FloatArray

ArrayLike = npt.ArrayLike


# ---------------------------------------------------------------------------------------------
# Classical two-phase models (no contact resistance)


def wiener_parallel(phi: ArrayLike, kappa: ArrayLike) -> FloatArray:
    """Wiener (1912) parallel (arithmetic) bound, ``E = 1 - phi + phi kappa`` (effective_formulas.md §1).

    Upper bound of any isotropic or anisotropic two-phase medium with perfect contact.
    """
    p, k = check_phi(phi), check_kappa(kappa)
    return np.asarray(1.0 + p * (k - 1.0))


def wiener_series(phi: ArrayLike, kappa: ArrayLike) -> FloatArray:
    """Wiener (1912) series (harmonic) bound, ``E = 1 / (1 - phi + phi / kappa)`` (effective_formulas.md §1)."""
    p, k = check_phi(phi), check_kappa(kappa)
    return np.asarray(1.0 / (1.0 + p * (1.0 / k - 1.0)))


def _maxwell_from_beta(p: FloatArray, beta: FloatArray) -> FloatArray:
    """``1 + 3 phi beta / (1 - phi beta)``; ``|beta| <= 1`` keeps the denominator >= 1 - phi > 0."""
    return np.asarray(1.0 + 3.0 * p * beta / (1.0 - p * beta))


def _beta(order: int, s: FloatArray) -> FloatArray:
    """Multipole polarisability ``beta_l = (kappa_l - 1)/(kappa_l + (l+1)/l)`` with ``kappa_l = 1/s``.

    Written in ``s = D + l C`` (effective_formulas.md §4, §7) so that perfectly conducting spheres
    (``s = 0``) and the neutral inclusion (``s = 1``) are regular: ``beta_l = (1 - s)/(1 + s (l+1)/l)``.
    """
    return np.asarray((1.0 - s) / (1.0 + s * (order + 1.0) / order))


def maxwell_eucken(phi: ArrayLike, kappa: ArrayLike) -> FloatArray:
    """Maxwell (1873) / Eucken (1932) model for dilute spheres (effective_formulas.md §3).

    ``E = (kappa + 2 + 2 phi (kappa - 1)) / (kappa + 2 - phi (kappa - 1)) = 1 + 3 phi beta / (1 - phi beta)``
    with ``beta = (kappa - 1)/(kappa + 2)``; identical to the Hashin-Shtrikman matrix bound.
    """
    p, k = check_phi(phi), check_kappa(kappa)
    return _maxwell_from_beta(p, _beta(1, 1.0 / k))


def _hs_particle(p: FloatArray, k: FloatArray) -> FloatArray:
    """Hashin-Shtrikman bound with the filler as reference (effective_formulas.md §2).

    ``kappa + (1-phi) / (1/(1-kappa) + phi/(3 kappa))`` rewritten without the pole at kappa = 1:
    ``(3 + 2 phi (kappa - 1)) / (3 - phi (1 - 1/kappa))``.
    """
    return np.asarray((3.0 + 2.0 * p * (k - 1.0)) / (3.0 - p * (1.0 - 1.0 / k)))


def hashin_shtrikman_lower(phi: ArrayLike, kappa: ArrayLike) -> FloatArray:
    """Hashin & Shtrikman (1962) lower bound for isotropic two-phase media (effective_formulas.md §2).

    The matrix-reference bound (= Maxwell-Eucken) when ``kappa >= 1``, the filler-reference
    bound when ``kappa < 1``.
    """
    p, k = check_phi(phi), check_kappa(kappa)
    matrix_ref = _maxwell_from_beta(p, _beta(1, 1.0 / k))
    return np.asarray(np.where(k >= 1.0, matrix_ref, _hs_particle(p, k)))


def hashin_shtrikman_upper(phi: ArrayLike, kappa: ArrayLike) -> FloatArray:
    """Hashin & Shtrikman (1962) upper bound (effective_formulas.md §2): filler reference when ``kappa >= 1``."""
    p, k = check_phi(phi), check_kappa(kappa)
    matrix_ref = _maxwell_from_beta(p, _beta(1, 1.0 / k))
    return np.asarray(np.where(k >= 1.0, _hs_particle(p, k), matrix_ref))


def hasselman_johnson(phi: ArrayLike, kappa: ArrayLike, contact: ArrayLike = 0.0) -> FloatArray:
    """Hasselman & Johnson (1987): dilute spheres with interfacial resistance (effective_formulas.md §4).

    Maxwell's formula with the dipole-equivalent filler conductivity ``kappa_1 = 1/(D + C)``,
    ``D = 1/kappa``, ``C = R_c lambda_m / a``.  ``C = 0`` gives Maxwell-Eucken; ``D + C = 1``
    (neutral inclusion) gives exactly 1.
    """
    p, k, c = check_phi(phi), check_kappa(kappa), check_contact(contact)
    return _maxwell_from_beta(p, _beta(1, 1.0 / k + c))


# ---------------------------------------------------------------------------------------------
# Hatta-Taya (spheroids)

# Taylor coefficients of S11(p) about p = 1 (t = p - 1), from sympy; valid for both prolate and oblate.
_S11_SERIES = (1 / 3, 2 / 15, -3 / 35, 16 / 315, -20 / 693, 16 / 1001, -56 / 6435, 512 / 109395)
_SERIES_RADIUS = 0.02  # |p - 1| below which the series (error < 1e-15) replaces the closed forms


def depolarization_factors(aspect: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Depolarisation factors ``(S11, S33)`` of a spheroid with axis ratio ``p = c/a`` (effective_formulas.md §5).

    Prolate (``p > 1``): ``S11 = p/(2 (p^2-1)^{3/2}) [p sqrt(p^2-1) - acosh p]``; oblate
    (``p < 1``): ``S11 = p/(2 (1-p^2)^{3/2}) [acos p - p sqrt(1-p^2)]``; ``S33 = 1 - 2 S11``.
    Both closed forms cancel catastrophically near the sphere ``p = 1``, where their common
    Taylor series is used instead.
    """
    p = checked("aspect (spheroid axis ratio)", aspect, 0.0, low_open=True)
    t = p - 1.0
    near = np.abs(t) < _SERIES_RADIUS
    series = np.polynomial.polynomial.polyval(np.where(near, t, 0.0), _S11_SERIES)
    pro = np.where(p > 1.0 + _SERIES_RADIUS / 2, p, 2.0)
    obl = np.where(p < 1.0 - _SERIES_RADIUS / 2, p, 0.5)
    q_pro = np.sqrt(pro * pro - 1.0)
    q_obl = np.sqrt(1.0 - obl * obl)
    s_pro = pro / (2.0 * q_pro**3) * (pro * q_pro - np.arccosh(pro))
    s_obl = obl / (2.0 * q_obl**3) * (np.arccos(obl) - obl * q_obl)
    s11 = np.where(near, series, np.where(p > 1.0, s_pro, s_obl))
    return np.asarray(s11), np.asarray(1.0 - 2.0 * s11)


def hatta_taya(phi: ArrayLike, kappa: ArrayLike, aspect: ArrayLike = 1.0,
               orientation: Literal["random", "axial", "transverse"] = "random") -> FloatArray:
    """Hatta & Taya (1985, 1986) equivalent-inclusion (Mori-Tanaka) model for spheroids (effective_formulas.md §5).

    ``orientation="random"`` (3-D random orientation)::

        E = 1 + phi d [3 + d (2 S33 + S11)] / (3 + d [3 (S11 + S33) - phi (2 S11 + S33)]
                                              + 3 (1 - phi) d^2 S11 S33),      d = kappa - 1;

    ``"axial"`` / ``"transverse"``: aligned spheroids, flux along / across their axis,
    ``E_ii = 1 + phi d / (1 + S_ii (1 - phi) d)``.  For spheres (``aspect = 1``) every form
    equals Maxwell-Eucken.
    """
    p, k = check_phi(phi), check_kappa(kappa)
    s11, s33 = depolarization_factors(aspect)
    d = k - 1.0
    if orientation == "random":
        num = p * d * (3.0 + d * (2.0 * s33 + s11))
        den = 3.0 + d * (3.0 * (s11 + s33) - p * (2.0 * s11 + s33)) + 3.0 * (1.0 - p) * d * d * s11 * s33
        return np.asarray(1.0 + num / den)
    if orientation in ("axial", "transverse"):
        s = s33 if orientation == "axial" else s11
        return np.asarray(1.0 + p * d / (1.0 + s * (1.0 - p) * d))
    raise InputError(f"orientation must be 'random', 'axial' or 'transverse'; got {orientation!r}")


# ---------------------------------------------------------------------------------------------
# Lewis-Nielsen


def lewis_nielsen(phi: ArrayLike, kappa: ArrayLike, shape_factor: ArrayLike = 1.5,
                  phi_max: ArrayLike = PHI_MAX_SC) -> FloatArray:
    """Lewis & Nielsen (1970) / Nielsen (1974) semi-empirical model (effective_formulas.md §6).

    ``E = (1 + A beta phi) / (1 - beta psi phi)``, ``beta = (kappa-1)/(kappa+A)``,
    ``psi = 1 + phi (1 - phi_m)/phi_m^2``.  Defaults: spheres (``A = 1.5``) and the maximum
    packing of the simple-cubic cell of [GarnierDanes], ``phi_m = pi/6``.  ``A = 2, phi_m = 1``
    gives Maxwell-Eucken.
    """
    k = check_kappa(kappa)
    a = checked("shape_factor A", shape_factor, 0.0, low_open=True)
    pm = checked("phi_max", phi_max, 0.0, 1.0, low_open=True)
    p = check_phi(phi)
    if np.any(p > pm):
        raise InputError(f"phi must not exceed phi_max = {np.max(pm):g} in Lewis-Nielsen; got {np.max(p):g}")
    beta = (k - 1.0) / (k + a)
    psi = 1.0 + p * (1.0 - pm) / (pm * pm)
    return np.asarray((1.0 + a * beta * p) / (1.0 - beta * psi * p))


# ---------------------------------------------------------------------------------------------
# Simple-cubic array: Rayleigh's formula and the three-point parameter zeta_2

# effective_formulas.md §7: lattice-sum coefficients computed by Ewald summation (this work), cf. Sangani &
# Acrivos (1983); c1 replaces Rayleigh's 1.65 by 1.3047.
_RAYLEIGH = {"c1": 1.3047180, "c3": 0.4054096, "c4": 0.0723171, "c5": 0.1525602, "c6": 0.0104482,
             "a2": 0.2350}


def rayleigh_simple_cubic(phi: ArrayLike, kappa: ArrayLike, contact: ArrayLike = 0.0) -> FloatArray:
    """Rayleigh (1892) formula for the simple-cubic sphere array with higher-order terms (effective_formulas.md §7).

    ::

        E = 1 + 3 phi / (1/beta1 - phi - c1 beta3 phi^{10/3} (1 + a2 beta5 phi^{11/3}) / (1 - c3 beta3 phi^{7/3})
                         - c4 beta5 phi^{14/3} - c5 beta7 phi^6 - c6 beta9 phi^{22/3})

    with ``beta_l`` of the mode-``l`` equivalent conductivity ``kappa_l = 1/(D + l C)`` (exact
    substitution for interfacial resistance).  Relative error against exact SC values:
    < 2e-6 for phi <= 0.2, 1.3e-4 at 0.3, 4e-3 at 0.4, up to 11 % at 0.5 (perfect conductors);
    use it as the exact cell value only for phi <= 0.3.  Evaluated as
    ``1 + 3 phi beta1 / (1 - beta1 (phi + ...))`` so that ``beta1 = 0`` is regular.
    """
    p, k, c = check_phi(phi, PHI_MAX_SC), check_kappa(kappa), check_contact(contact)
    d = 1.0 / k
    b1, b3, b5, b7, b9 = (_beta(order, d + order * c) for order in (1, 3, 5, 7, 9))
    r = _RAYLEIGH
    tail = (p + r["c1"] * b3 * p ** (10 / 3) * (1.0 + r["a2"] * b5 * p ** (11 / 3))
            / (1.0 - r["c3"] * b3 * p ** (7 / 3))
            + r["c4"] * b5 * p ** (14 / 3) + r["c5"] * b7 * p**6 + r["c6"] * b9 * p ** (22 / 3))
    return np.asarray(1.0 + 3.0 * p * b1 / (1.0 - b1 * tail))


# effective_formulas.md §8: zeta_2 of the simple-cubic array (weak-contrast expansion of the multipole solution).
_ZETA2_PHI = np.array([0.05, 0.10, 4.0 * np.pi / 81.0, 0.20, 0.30, 0.40, 0.45, 0.50, 0.52])
_ZETA2_VAL = np.array([4.0703e-5, 4.3387e-4, 2.0034e-3, 4.9474e-3, 0.022026, 0.067808, 0.110309,
                       0.173764, 0.206994])
_ZETA2_SLOPE = 9.0 * _RAYLEIGH["c1"] / 14.0  # small-phi asymptote zeta2 ~ (9 c1/14) phi^{10/3}/(1-phi)


def _zeta2_asymptote(p: FloatArray) -> FloatArray:
    return np.asarray(_ZETA2_SLOPE * p ** (10 / 3) / (1.0 - p))


_ZETA2_RATIO = PchipInterpolator(np.concatenate([[0.0], _ZETA2_PHI]),
                                 np.concatenate([[1.0], _ZETA2_VAL / _zeta2_asymptote(_ZETA2_PHI)]),
                                 extrapolate=True)


def zeta2_simple_cubic(phi: ArrayLike) -> FloatArray:
    """Milton's three-point parameter zeta_2 of the simple-cubic sphere array (effective_formulas.md §8 table).

    Interpolated as ``zeta2 = r(phi) * (9 c1/14) phi^{10/3}/(1 - phi)``: the ratio ``r`` to the
    exact small-phi asymptote is smooth (1 at phi = 0, 1.048 at 0.52) and is interpolated
    monotonically (PCHIP) through the tabulated values; 0.52 < phi <= pi/6 is a short
    extrapolation (0.0036 in phi).  The random-dispersion value must not be used for the SC cell.
    """
    p = check_phi(phi, PHI_MAX_SC)
    return np.asarray(_ZETA2_RATIO(p) * _zeta2_asymptote(p))


# ---------------------------------------------------------------------------------------------
# Torquato-Rintoul third-order bounds with interfacial resistance


def _quotient(num: FloatArray, den: FloatArray) -> FloatArray:
    """``num/den`` where both vanish only together (contrast 1 without contact): the limit 0 there."""
    safe = np.where(den > 0.0, den, 1.0)
    return np.asarray(np.where(den > 0.0, num / safe, 0.0))


def _tr_inputs(phi: ArrayLike, kappa: ArrayLike, contact: ArrayLike,
               xi: ArrayLike | None) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    p, k, c = check_phi(phi), check_kappa(kappa), check_contact(contact)
    x = zeta2_simple_cubic(p) if xi is None else checked("xi (microstructure parameter)", xi, 0.0, 1.0)
    return p, 1.0 / k, c, x


def torquato_rintoul_lower(phi: ArrayLike, kappa: ArrayLike, contact: ArrayLike = 0.0,
                           xi: ArrayLike | None = None) -> FloatArray:
    """Torquato & Rintoul (1995) third-order lower bound V3L with interfacial resistance [GarnierDanes].

    [GarnierDanes] transcription (effective_formulas.md §9), ``K = 1 - D - C``::

        E = 1 / (1 - phi + phi (D + 3C)
                 - 2 phi {(1-phi) K (1 - D - 3C) + 3C}^2 / ((1-phi) K^2 [3 - (1-D)(2 - 2 phi + xi)] + 3 C Phi)),
        Phi = 1 + 2 (C+D)^2 + phi K {4 (C+D) + K [8/27 + phi (5 + phi)/2]}.

    ``xi`` defaults to zeta_2 of the simple-cubic array (:func:`zeta2_simple_cubic`); at ``C = 0``
    the bound is Beran-Milton's with ``zeta_2 = xi``.  The bracket ``8/27 + phi(5+phi)/2`` is
    the hard-wired interfacial three-point parameter, of unconfirmed provenance (flagged
    in effective_formulas.md §9).  The denominator is a sum of non-negative terms (``3 - (1-D)(2-2 phi+xi) >=
    1 + 2 phi - xi > 0``) that vanishes only at ``D = 1, C = 0`` together with the numerator.
    """
    p, d, c, x = _tr_inputs(phi, kappa, contact, xi)
    kk = 1.0 - d - c
    phi_big = 1.0 + 2.0 * (c + d) ** 2 + p * kk * (4.0 * (c + d) + kk * (8.0 / 27.0 + p * (5.0 + p) / 2.0))
    num = 2.0 * p * ((1.0 - p) * kk * (1.0 - d - 3.0 * c) + 3.0 * c) ** 2
    den = (1.0 - p) * kk**2 * (3.0 - (1.0 - d) * (2.0 - 2.0 * p + x)) + 3.0 * c * phi_big
    return np.asarray(1.0 / (1.0 - p * (1.0 - d - 3.0 * c) - _quotient(num, den)))


def torquato_rintoul_upper(phi: ArrayLike, kappa: ArrayLike, contact: ArrayLike = 0.0,
                           xi: ArrayLike | None = None) -> FloatArray:
    """Torquato & Rintoul (1995) third-order upper bound V3U with interfacial resistance [GarnierDanes].

    [GarnierDanes] transcription (effective_formulas.md §9), ``K = 1 - D - C``::

        E = 1 - phi + phi/D - phi [(1-phi)(1-D) K + 3C]^2
                              / (3 (1-phi) D^2 K (1-D+C) + 9 D^2 C (1+C) + D (1-D) Xi),
        Xi = [(1-phi) K + 3C]^2 + 2 (1-phi) xi K^2.

    Evaluated with ``1 - phi + phi/D = 1 + phi (kappa - 1)`` and the first two denominator
    terms regrouped as ``3 D^2 [(1-phi)(1-D)^2 + 3C + (2+phi) C^2]`` (non-negative), so the only
    0/0 is at ``D = 1, C = 0``.  ``xi = 0`` gives Hasselman-Johnson; ``C = 0`` Beran-Milton.
    Diverges as ``D -> 0`` for ``C > 0`` (useless for highly conducting fillers).
    """
    p, d, c, x = _tr_inputs(phi, kappa, contact, xi)
    s = 1.0 - d
    kk = s - c
    xi_big = ((1.0 - p) * kk + 3.0 * c) ** 2 + 2.0 * (1.0 - p) * x * kk**2
    num = p * ((1.0 - p) * s * kk + 3.0 * c) ** 2
    den = 3.0 * d * d * ((1.0 - p) * s * s + 3.0 * c + (2.0 + p) * c * c) + d * s * xi_big
    return np.asarray(1.0 + p * (1.0 / d - 1.0) - _quotient(num, den))
