"""Closed-form solutions used as independent references in tests and notebooks.

``slab_dirichlet_series``: transient conduction in a slab 0 <= x <= L with fixed
temperatures T(0) = T_left, T(L) = T_right and a uniform initial temperature T0
[Hassan2019, eq. 11-13, after Weigand 2004]:

    T(x, t) = T_1 + x dT / L + dT sum_{n>=1} C_n sin(n pi x / L) exp(-(n pi / L)^2 alpha t),
    C_n = 2 ((-1)^n (1 - theta_0) + theta_0) / (n pi),   theta_0 = (T0 - T_1) / dT,

with ``T_1 = T_left``, ``dT = T_right - T_left`` and ``alpha = lambda / (rho c)`` (m^2/s).
The series converges like 1/n at t = 0 (Gibbs oscillations at the walls) and
exponentially for t > 0: the truncation error after N terms is below
``2 |dT| max(|theta_0|, |1 - theta_0|) exp(-(N pi/L)^2 alpha t) / (N pi (1 - exp(...)))``.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.system import FloatArray


def slab_dirichlet_series(  # noqa: PLR0917 - positional signature agreed with the FE tests
    x: npt.ArrayLike,
    t: npt.ArrayLike,
    L: float,
    alpha: float,
    T0: float,
    T_left: float,
    T_right: float,
    n_terms: int = 200,
) -> FloatArray:
    """Temperature of the slab at positions ``x`` (m) and times ``t`` (s), [Hassan2019, eq. 12-13].

    ``x`` and ``t`` broadcast against each other (e.g. ``x[None, :]`` and ``t[:, None]``
    for a (times, positions) table).  If ``T_right == T_left`` the series is that of the
    uniform initial excess ``T0 - T_left`` decaying between two walls at ``T_left``.
    """
    if L <= 0 or alpha <= 0:
        raise InputError(f"slab: L and alpha must be positive, got L={L}, alpha={alpha}")
    if n_terms < 1:
        raise InputError(f"slab: n_terms must be >= 1, got {n_terms}")
    xa, ta = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(t, dtype=float))
    if np.any(ta < 0):
        raise InputError("slab: times must be non-negative")
    n = np.arange(1, n_terms + 1, dtype=float)
    k = n * np.pi / L
    dtemp = T_right - T_left
    # coefficients of dT * C_n, written so that dT = 0 (no imposed difference) is allowed
    sign = (-1.0) ** n
    amp = 2.0 * (sign * (dtemp - (T0 - T_left)) + (T0 - T_left)) / (n * np.pi)
    modes = np.sin(k * xa[..., None]) * np.exp(-(k**2) * alpha * ta[..., None])
    return np.asarray(T_left + xa * dtemp / L + modes @ amp)
