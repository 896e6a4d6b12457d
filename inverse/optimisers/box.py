"""Normalised search coordinates ``u ∈ [0, 1]^p`` for bounded unknowns.

Linear in a parameter whose bounds span less than two decades, logarithmic otherwise (e.g. a capacity
c_F ∈ [1e5, 1e7] J/(m³ K)).  Every optimiser works in these coordinates.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray

LOG_DECADES = 2.0  # bounds spanning this many decades or more are searched in log scale


@dataclass(frozen=True)
class Box:
    """Bounds of the unknowns and the map ``u ∈ [0,1]^p`` ↔ physical values θ."""

    names: tuple[str, ...]
    lower: FloatArray
    upper: FloatArray
    log: tuple[bool, ...]

    @classmethod
    def from_bounds(cls, unknowns: Mapping[str, tuple[float, float]]) -> Box:
        if not unknowns:
            raise InputError("no unknowns: give at least one parameter with bounds, e.g. fibre.k=(0.05, 1.0)")
        lo, hi, log = [], [], []
        for name, bounds in unknowns.items():
            try:
                a, b = (float(v) for v in bounds)
            except (TypeError, ValueError):
                raise InputError(f"unknown {name!r}: bounds must be two numbers (lower, upper), "
                                 f"got {bounds!r}") from None
            if not (math.isfinite(a) and math.isfinite(b) and a < b):
                raise InputError(f"unknown {name!r}: bounds must be finite with lower < upper, got ({a:g}, {b:g})")
            lo.append(a)
            hi.append(b)
            log.append(a > 0 and math.log10(b / a) >= LOG_DECADES)
        return cls(tuple(unknowns), np.array(lo), np.array(hi), tuple(log))

    @property
    def dim(self) -> int:
        return len(self.names)

    def _ends(self) -> tuple[FloatArray, FloatArray]:
        lg = np.array(self.log)
        return (np.where(lg, np.log(np.where(lg, self.lower, 1.0)), self.lower),
                np.where(lg, np.log(np.where(lg, self.upper, 1.0)), self.upper))

    def to_physical(self, u: FloatArray) -> FloatArray:
        a, b = self._ends()
        s = a + np.asarray(u, dtype=float) * (b - a)
        lg = np.array(self.log)
        return np.where(lg, np.exp(np.where(lg, s, 0.0)), s)  # exp only on log axes (a linear c ~ 1e6 overflows)

    def to_unit(self, theta: FloatArray) -> FloatArray:
        a, b = self._ends()
        t = np.asarray(theta, dtype=float)
        s = np.where(np.array(self.log), np.log(np.where(np.array(self.log), t, 1.0)), t)
        return (s - a) / (b - a)

    def dtheta_du(self, u: FloatArray) -> FloatArray:
        """Derivative of θ with respect to u, elementwise (the map is diagonal)."""
        a, b = self._ends()
        return np.where(np.array(self.log), self.to_physical(u) * (b - a), b - a)

    def as_dict(self) -> dict[str, tuple[float, float]]:
        return {n: (float(a), float(b)) for n, a, b in zip(self.names, self.lower, self.upper, strict=True)}
