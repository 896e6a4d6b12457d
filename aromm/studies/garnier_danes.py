"""Table 1 and the preference map of [GarnierDanes]: bounds against the finite-element cell value.

``eps_X = 100 ln(E_X / E_c)`` [GarnierDanes, Table 1] for the lower bounds V3L, W_inf_a, W1a and the
upper bounds W1b, W_inf_b, V3U, over a (B, C, D) grid, with ``E_c`` the exact cell value
computed by conforming finite elements (:mod:`aromm.bounds.cell_fem`).  [GarnierDanes] does not
give its grid; :data:`COARSE` (CI, about a minute) and :data:`FULL` are ours.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.optimize import brentq

from aromm.bounds.cell_fem import CellModel
from aromm.bounds.domain import cell_phi
from aromm.bounds.models import torquato_rintoul_lower, torquato_rintoul_upper
from aromm.bounds.wall import wall_1a, wall_1b, wall_inf_a, wall_inf_b
from aromm.core.errors import NumericalError
from aromm.core.system import FloatArray

# [GarnierDanes, Table 1]: logarithmic deviation eps (%), average / min / max (W1b is not in the poster's table).
SEED_TABLE1: dict[str, tuple[float, float, float]] = {
    "V3L": (-28.0, -127.0, -2.0),
    "W_inf_a": (-13.0, -45.0, -6.0),
    "W1a": (-3.0, -6.0, -1.0),
    "W_inf_b": (97.0, 4.0, 332.0),
    "V3U": (368.0, 6.0, 827.0),
}
# [GarnierDanes], preference map: V3L is the tighter lower bound for C >= 0.1081 (any B, D) or D >= 0.0496 (any B, C).
SEED_PREFERENCE = {"C": 0.1081, "D": 0.0496}

LOWER = ("V3L", "W_inf_a", "W1a")
UPPER = ("W1b", "W_inf_b", "V3U")


@dataclass(frozen=True)
class Grid:
    """Cell parameters B, contact resistances C, inverse contrasts D, and the FE mesh size h (units of a)."""

    B: tuple[float, ...]
    C: tuple[float, ...]
    D: tuple[float, ...]
    h: float

    @property
    def size(self) -> int:
        return len(self.B) * len(self.C) * len(self.D)


COARSE = Grid(B=(0.1, 0.3, 1.0), C=(0.0, 0.1, 1.0), D=(0.01, 0.1, 0.5), h=0.4)
FULL = Grid(B=(0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0), C=(0.0, 0.01, 0.05, 0.1, 0.2, 0.5, 1.0, 5.0),
            D=(0.001, 0.01, 0.05, 0.1, 0.2, 0.5, 1.0), h=0.3)


@dataclass(frozen=True)
class GridPoint:
    """One (B, C, D) of the grid: the FE values and every bound, ``E = lambda_eff / lambda_m``."""

    B: float
    C: float
    D: float
    phi: float
    E_c: float
    E_c_coarse: float
    E_II: float
    E_1bot: float
    bounds: dict[str, float]

    @property
    def mesh_change(self) -> float:
        """``100 |ln(E_c(h) / E_c(1.5 h))|`` (%): how much E_c still moves under refinement, a rough
        indicator of its discretisation error (not a bound: on these coarse meshes the observed
        rate is ~1.3-2 in N^(-1/3), benchmarks/bounds_fem.py)."""
        return float(100.0 * abs(np.log(self.E_c / self.E_c_coarse)))

    def eps(self, name: str) -> float:
        """``100 ln(E_X / E_c)`` (%)."""
        return float(100.0 * np.log(self.bounds[name] / self.E_c))


def evaluate_grid(grid: Grid, progress: Callable[[str], None] | None = None) -> list[GridPoint]:
    """FE cell values and bounds at every grid point (three meshes per B, reused for all C and D)."""
    points = []
    for b in grid.B:
        if progress is not None:
            progress(f"B = {b:g}: meshing and assembling the cell, cylinder and slab (h = {grid.h:g} a)")
        cell, cylinder, slab = (CellModel(kind, b, grid.h) for kind in ("cell", "cylinder", "slab"))
        cell_coarse = CellModel("cell", b, 1.5 * grid.h)
        phi = float(cell_phi(b))
        for c in grid.C:
            for d in grid.D:
                e_c, e_ii, e_bot = cell.E(c, d), cylinder.E(c, d), slab.E(c, d)
                bounds = {
                    "V3L": float(torquato_rintoul_lower(phi, 1.0 / d, c)),
                    "W_inf_a": float(wall_inf_a(b, c, d)),
                    "W1a": float(wall_1a(b, e_ii)),
                    "W1b": float(wall_1b(b, e_bot)),
                    "W_inf_b": float(wall_inf_b(b, c, d)),
                    "V3U": float(torquato_rintoul_upper(phi, 1.0 / d, c)),
                }
                points.append(GridPoint(b, c, d, phi, e_c, cell_coarse.E(c, d), e_ii, e_bot, bounds))
    return points


def deviation_table(points: Sequence[GridPoint]) -> dict[str, tuple[float, float, float]]:
    """Average, min and max of ``eps`` (%) per bound, as in [GarnierDanes, Table 1]."""
    out = {}
    for name in LOWER + UPPER:
        e = np.array([p.eps(name) for p in points])
        out[name] = (float(e.mean()), float(e.min()), float(e.max()))
    return out


def ordering_violations(points: Sequence[GridPoint]) -> list[tuple[GridPoint, str, float]]:
    """Grid points where a lower bound exceeds E_c or an upper bound is below it, with eps (%).

    Compare ``|eps|`` with :attr:`GridPoint.mesh_change` and, for phi <= 0.3, with the exact value
    (Rayleigh's series): a violation smaller than the FE error is not resolved by the mesh."""
    bad = []
    for p in points:
        bad += [(p, name, p.eps(name)) for name in LOWER if p.eps(name) > 0.0]
        bad += [(p, name, p.eps(name)) for name in UPPER if p.eps(name) < 0.0]
    return bad


def preference_map(B: npt.ArrayLike, C: npt.ArrayLike, D: npt.ArrayLike) -> FloatArray:
    """``100 ln(E_V3L / E_W_inf_a)`` on the broadcast (B, C, D): > 0 where V3L is the tighter lower bound.

    Both bounds are closed forms, so the map is computed on fine grids (``D > 0``).
    """
    v3l = torquato_rintoul_lower(cell_phi(B), 1.0 / np.asarray(D, dtype=float), C)
    return np.asarray(100.0 * np.log(v3l / wall_inf_a(B, C, D)))


def preference_thresholds(B: npt.ArrayLike, C: npt.ArrayLike, D: npt.ArrayLike) -> tuple[float, float]:
    """The two statements of [GarnierDanes] as thresholds on the given 1-D axes.

    Returns ``(C*, D*)``: the largest C, and the largest D, at which W_inf_a is still the tighter
    lower bound for some (B, D), resp. (B, C), of the axes; NaN when V3L is tighter everywhere.
    """
    b, c, d = np.meshgrid(B, C, D, indexing="ij")
    w_tighter = preference_map(b, c, d) < 0.0
    if not np.any(w_tighter):
        return float("nan"), float("nan")
    return float(c[w_tighter].max()), float(d[w_tighter].max())


@dataclass(frozen=True)
class PreferenceBoundary:
    """Where W_inf_a stops (or starts) being the tighter lower bound, for one cell parameter B.

    ``d_star``: largest D at which W_inf_a is tighter with perfect contact (C = 0);
    ``c_star``: largest C at which it is tighter for perfectly conducting spheres (D -> 0);
    ``c_large``: C above which W_inf_a is tighter again for D -> 0 (the large-resistance region);
    NaN where the region does not exist.
    """

    B: float
    d_star: float
    c_star: float
    c_large: float


_D_ZERO = 1e-12  # "perfectly conducting" in the closed forms, which need D > 0 for V3L


def _crossings(f: Callable[[float], float], axis: FloatArray) -> list[float]:
    """Roots of ``f`` bracketed by sign changes on ``axis`` (brentq, xtol 1e-12)."""
    values = np.array([f(float(x)) for x in axis])
    roots = []
    for i in np.flatnonzero(np.sign(values[:-1]) * np.sign(values[1:]) < 0):
        root, info = brentq(f, float(axis[i]), float(axis[i + 1]), xtol=1e-12, full_output=True)
        if not info.converged:
            raise NumericalError(f"brentq did not bracket the preference boundary: {info.flag}")
        roots.append(float(root))
    return roots


def preference_boundary(B: float) -> PreferenceBoundary:
    """The boundaries of the V3L / W_inf_a preference map on the axes C = 0 and D -> 0 (see class)."""
    d_roots = _crossings(lambda d: float(preference_map(B, 0.0, d)), np.geomspace(1e-8, 1.0, 161))
    c_roots = _crossings(lambda c: float(preference_map(B, c, _D_ZERO)), np.geomspace(1e-6, 100.0, 241))
    w_at_zero = float(preference_map(B, 0.0, _D_ZERO)) < 0.0
    c_star = c_roots[0] if (w_at_zero and c_roots) else float("nan")
    rising = [r for r in c_roots if r != c_star]
    return PreferenceBoundary(B=B, d_star=d_roots[0] if (w_at_zero and d_roots) else float("nan"),
                              c_star=c_star, c_large=rising[0] if rising else float("nan"))
