"""An independent one-dimensional reference for layered bodies (not a test module itself).

A body made of layers normal to z, loaded uniformly on its z faces and adiabatic elsewhere, is exactly
one-dimensional: the voxel Q1 solution is uniform in x and y and equals the 1-D linear finite-element
solution on the same z nodes (consistent mass; Q1 = P1 ⊗ P1 ⊗ P1).  This module assembles that 1-D
model by hand and integrates its semi-discrete equation ``M ẏ = −K y + f(t)`` exactly for loads that
are piecewise linear in time, by the matrix exponential of the augmented system (Van Loan): on an
interval where ``f = f_a + s f_1``, ``w = [y, 1, s]`` obeys ``ẇ = G w`` with

    G = [[−M⁻¹K, M⁻¹f_a, M⁻¹f_1], [0, 0, 0], [0, 1, 0]],     w(a + s) = expm(G s) w(a).

Nothing here shares code with aromm's reduced model (eigen-decomposition and φ functions) or its
full model (BDF2).  Fixed temperatures ``g(t)`` at an end are eliminated with their mass and stiffness
couplings ``−K_fd g − M_fd ġ``.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

History = Callable[[float], float]


@dataclass(frozen=True)
class Slab:
    """Layers of thickness ``dz`` (m) with conductivities ``k`` (W/(m K)) and capacities ``c`` (J/(m³ K))."""

    k: np.ndarray
    c: np.ndarray
    dz: float

    @property
    def nodes(self) -> int:
        return self.k.size + 1

    def matrices(self, h_end: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Consistent mass M and stiffness K per unit area; ``h_end`` adds convection at the last node."""
        n = self.nodes
        m, kk = np.zeros((n, n)), np.zeros((n, n))
        for e in range(self.k.size):
            idx = np.ix_([e, e + 1], [e, e + 1])
            m[idx] += self.c[e] * self.dz / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
            kk[idx] += self.k[e] / self.dz * np.array([[1.0, -1.0], [-1.0, 1.0]])
        kk[-1, -1] += h_end
        return m, kk


def _piecewise(times: np.ndarray, breaks: Sequence[float]) -> np.ndarray:
    end = float(times.max())
    inner = [b for b in breaks if 0.0 < b < end]
    return np.unique(np.concatenate([[0.0], inner, [end]]))


def solve(slab: Slab, times: np.ndarray, *, flux: History = lambda t: 0.0, h: float = 0.0,
          t_ext: History = lambda t: 0.0, fixed_first: History | None = None, fixed_last: History | None = None,
          initial: float = 0.0, breaks: Sequence[float] = ()) -> np.ndarray:
    """Nodal temperatures (len(times), nodes): flux (W/m²) into node 0, convection h to t_ext at the last node,
    or fixed temperatures at either end; every history linear between the ``breaks`` (s)."""
    m, k = slab.matrices(h if fixed_last is None else 0.0)
    n = slab.nodes
    fixed = [i for i, g in ((0, fixed_first), (n - 1, fixed_last)) if g is not None]
    histories = {0: fixed_first, n - 1: fixed_last}
    free = np.array([i for i in range(n) if i not in fixed])

    def load(t: float) -> np.ndarray:
        """f − K g at time t (the histories are continuous: one value at a breakpoint)."""
        f = np.zeros(n)
        if fixed_first is None:
            f[0] += flux(t)
        if fixed_last is None:
            f[-1] += h * t_ext(t)
        g = np.zeros(n)
        for i in fixed:
            hist = histories[i]
            assert hist is not None
            g[i] = hist(t)
        return f - k @ g

    m_ff, k_ff = m[np.ix_(free, free)], k[np.ix_(free, free)]
    minv = np.linalg.inv(m_ff)
    y = np.full(free.size, float(initial))
    out = np.empty((times.size, n))
    edges = _piecewise(times, breaks)
    size = free.size
    for a, b in itertools.pairwise(edges):
        span = b - a
        fa, fb = load(a), load(b)
        slope = (fb - fa) / span  # the loads are linear on [a, b]
        # the mass coupling −M_fd ġ of the fixed values, constant on [a, b]
        moving = np.zeros(n)
        for i in fixed:
            hist = histories[i]
            assert hist is not None
            moving[i] = (hist(b) - hist(a)) / span
        fa = (fa - m @ moving)[free]
        slope = slope[free]
        g = np.zeros((size + 2, size + 2))
        g[:size, :size] = -minv @ k_ff
        g[:size, size] = minv @ fa
        g[:size, size + 1] = minv @ slope
        g[size + 1, size] = 1.0
        steps: dict[float, np.ndarray] = {}  # expm(G s) by step length: uniform output times reuse one

        def advance(w: np.ndarray, s: float, g: np.ndarray = g, steps: dict[float, np.ndarray] = steps) -> np.ndarray:
            key = round(s, 12)
            if key not in steps:
                steps[key] = sla.expm(g * s)
            return steps[key] @ w

        w, at = np.concatenate([y, [1.0, 0.0]]), a
        inside = (times > a) & (times <= b) if a > 0 else (times >= a) & (times <= b)
        for i in np.flatnonzero(inside)[np.argsort(times[inside])]:
            w, at = advance(w, times[i] - at), times[i]
            out[i, free] = w[:size]
        y = advance(w, b - at)[:size]
    for i in fixed:
        hist = histories[i]
        assert hist is not None
        out[:, i] = [hist(float(t)) for t in times]
    return out
