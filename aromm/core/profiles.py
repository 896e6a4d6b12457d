"""Known functions of time that multiply a term of a ThermalSystem: piecewise-linear load histories.

A face's ``flux``, ``T_ext`` or ``T`` may be a table of rows ``(t_i, g_i)`` read from a CSV file
(docs/design.md "Scene file").  The term it drives keeps its affine coefficient, which becomes a
dimensionless *scale* of the table (default 1)::

    F(p, t) = Σ_j c_j(p) g_j(t) F_j,          g_j ≡ 1 for a constant term,

so the full model evaluates ``g_j`` at its step times and the reduced model integrates the modal
equations exactly between the breakpoints ``t_i`` (:mod:`aromm.reduction.rom`).  Two kinds exist:

* ``"linear"``: linear interpolation between rows, held at the first value before the first row and
  at the last value after the last row (continuous);
* ``"steps"``: ``g_i`` on ``[t_i, t_{i+1})``, ``g_last`` after the last row, 0 before the first row
  (the derivative of a linear profile: the lifting of a time-varying fixed temperature,
  :mod:`aromm.reduction.lifting`, needs it).

Either kind is linear between consecutive breakpoints, which is all the exact integrator needs:
:meth:`Profile.limits` gives the one-sided values at the ends of such an interval.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError

FloatArray = npt.NDArray[np.float64]
Kind = Literal["linear", "steps"]
KINDS: tuple[Kind, ...] = ("linear", "steps")


@dataclass(frozen=True, eq=False)
class Profile:
    """A piecewise-linear (``"linear"``) or piecewise-constant (``"steps"``) function of time t (s).

    ``times`` strictly increasing and ≥ 0, ``values`` finite, of equal length ≥ 1; ``source`` names
    the file it came from in messages.

    >>> g = Profile((0.0, 1.0, 3.0), (0.0, 2.0, 2.0))
    >>> g(np.array([0.5, 2.0, 10.0])).tolist()
    [1.0, 2.0, 2.0]
    >>> g.derivative()(np.array([0.5, 2.0, 10.0])).tolist()
    [2.0, 0.0, 0.0]
    """

    times: tuple[float, ...]
    values: tuple[float, ...]
    kind: Kind = "linear"
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        where = f"{self.source}: " if self.source else ""
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        if self.kind not in KINDS:
            raise InputError(f"{where}unknown profile kind {self.kind!r}; allowed: {', '.join(KINDS)}")
        if t.ndim != 1 or t.size == 0 or t.shape != v.shape:
            raise InputError(f"{where}a profile needs as many values as times (at least one row), "
                             f"got {t.size} times and {v.size} values")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise InputError(f"{where}profile times and values must be finite")
        if t[0] < 0 or np.any(np.diff(t) <= 0):
            raise InputError(f"{where}profile times must be >= 0 and strictly increasing")

    def __call__(self, t: npt.ArrayLike) -> FloatArray:
        """g(t) at the times ``t`` (array of any shape)."""
        tt = np.asarray(t, dtype=float)
        if self.kind == "linear":
            return np.asarray(np.interp(tt, self.times, self.values), dtype=float)
        idx = np.searchsorted(np.asarray(self.times), tt, side="right") - 1
        vals = np.asarray(self.values, dtype=float)
        return np.where(idx >= 0, vals[np.clip(idx, 0, None)], 0.0)

    @property
    def breakpoints(self) -> FloatArray:
        """Times where g or its slope may jump (s); g is linear between consecutive ones."""
        return np.asarray(self.times, dtype=float)

    @property
    def final(self) -> float:
        """The value held after the last row (the steady limit)."""
        return float(self.values[-1])

    @property
    def is_constant(self) -> bool:
        """True when g takes one value for all t ≥ 0 (then its derivative vanishes)."""
        v = np.asarray(self.values, dtype=float)
        held = self.kind == "linear" or self.times[0] == 0.0 or v[0] == 0.0
        return held and bool(np.all(v == v[0]))

    def limits(self, a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray]:
        """One-sided values ``g(a+)`` and ``g(b−)`` on intervals ``(a, b)`` free of breakpoints (a < b)."""
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        if self.kind == "linear":
            return self(a), self(b)
        inside = self(0.5 * (a + b))
        return inside, inside

    def derivative(self) -> Profile:
        """dg/dt: a ``"steps"`` profile (slopes between rows, 0 after the last; only for ``"linear"``)."""
        if self.kind != "linear":
            raise InputError(f"{self.source or 'profile'}: only a linear profile has a piecewise-constant derivative")
        t = np.asarray(self.times, dtype=float)
        slopes = np.diff(np.asarray(self.values, dtype=float)) / np.diff(t)
        return Profile(self.times, (*slopes.tolist(), 0.0), "steps", f"d/dt {self.source}".strip())

    def describe(self) -> str:
        """Short readable form for messages and fingerprints."""
        return f"{self.kind} profile of {len(self.times)} rows{' from ' + self.source if self.source else ''}"

    def arrays(self) -> FloatArray:
        """(2, rows): times and values, for storage (:mod:`aromm.reduction.rom` serialisation, content hashes)."""
        return np.array([self.times, self.values], dtype=float)

    @classmethod
    def from_arrays(cls, data: npt.ArrayLike, kind: str, source: str = "") -> Profile:
        arr = np.asarray(data, dtype=float)
        if kind not in KINDS:
            raise InputError(f"unknown profile kind {kind!r}; allowed: {', '.join(KINDS)}")
        return cls(tuple(arr[0].tolist()), tuple(arr[1].tolist()), kind, source)  # type: ignore[arg-type]


def time_factor(profile: Profile | None, t: float) -> float:
    """g(t) of a term (1 for a term constant in time; ``t = inf`` gives the held final value)."""
    return 1.0 if profile is None else float(profile(t))
