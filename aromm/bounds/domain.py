"""Parameters of the simple-cubic (SC) cell of [GarnierDanes] and input checks shared by the models.

[GarnierDanes] ("Main features of the adopted models"): a sphere of radius ``a`` centred in a
``2b x 2b x 2b`` cell, with the dimensionless groups

    B = b/a - 1,        C = R_c lambda_m / a,        D = lambda_m / lambda_f,
    phi = pi / (6 (1 + B)^3)                                     (volume fraction),

so ``phi`` ranges over ``(0, pi/6]`` (touching spheres at B = 0).  ``kappa = 1/D`` is the
contrast lambda_f/lambda_m used by the classical models.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.system import FloatArray

PHI_MAX_SC = np.pi / 6.0  # touching spheres in the simple-cubic cell


def checked(name: str, value: npt.ArrayLike, low: float, high: float = np.inf, *,
            low_open: bool = False, high_open: bool = False) -> FloatArray:
    """``value`` as a float array, or :class:`InputError` naming ``name`` and the allowed range."""
    arr = np.asarray(value, dtype=float)
    bad = ~np.isfinite(arr)
    bad |= (arr <= low) if low_open else (arr < low)
    if np.isfinite(high):
        bad |= (arr >= high) if high_open else (arr > high)
    if np.any(bad):
        left = "(" if low_open else "["
        right = ")" if high_open or not np.isfinite(high) else "]"
        shown = arr[bad].ravel()[:3].tolist() if arr.ndim else [float(arr)]
        raise InputError(f"{name} must be finite and in {left}{low:g}, {high:g}{right}; got {shown}")
    return arr


def check_phi(phi: npt.ArrayLike, high: float = 1.0) -> FloatArray:
    """Volume fraction in (0, high]."""
    return checked("phi (volume fraction)", phi, 0.0, high, low_open=True)


def check_kappa(kappa: npt.ArrayLike) -> FloatArray:
    """Conductivity ratio kappa = lambda_f / lambda_m > 0 (finite)."""
    return checked("kappa (ratio lambda_f/lambda_m)", kappa, 0.0, low_open=True)


def check_contact(contact: npt.ArrayLike) -> FloatArray:
    """Dimensionless contact resistance C = R_c lambda_m / a >= 0."""
    return checked("C (contact resistance R_c lambda_m / a)", contact, 0.0)


def check_B(B: npt.ArrayLike) -> FloatArray:
    """Cell parameter B = b/a - 1 >= 0."""
    return checked("B (cell parameter b/a - 1)", B, 0.0)


def check_D(D: npt.ArrayLike) -> FloatArray:
    """Inverse contrast D = lambda_m / lambda_f >= 0 (D = 0: perfectly conducting filler)."""
    return checked("D (ratio lambda_m/lambda_f)", D, 0.0)


def cell_phi(B: npt.ArrayLike) -> FloatArray:
    """Volume fraction of the SC cell, phi = pi / (6 (1 + B)^3) [GarnierDanes]."""
    b = check_B(B)
    return np.asarray(np.pi / (6.0 * (1.0 + b) ** 3))


def cell_B(phi: npt.ArrayLike) -> FloatArray:
    """Cell parameter of the SC cell, B = (pi / (6 phi))^(1/3) - 1, inverse of :func:`cell_phi`."""
    p = check_phi(phi, PHI_MAX_SC)
    return np.asarray(np.maximum(np.cbrt(PHI_MAX_SC / p) - 1.0, 0.0))
