"""Shifted multigrid solves of the Krylov reduction: affine coarse levels and the rounding floor."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from test_multigrid import _system

from aromm.full.solve import _partition, _points, _split
from aromm.linalg.multigrid.affine import AffineGrid
from aromm.linalg.multigrid.assembled import GridMatrix
from aromm.linalg.multigrid.pcg import FLOOR_FACTOR, MultigridSolver

RTOL = 1e-10


def _terms(shape: tuple[int, int, int] = (17, 12, 19)):  # type: ignore[no-untyped-def]
    """Free-free blocks of every conductance and capacity term (x0 fixed: absent grid nodes), and their points."""
    system = _system(shape, contrast=1e3)
    part = _partition(system, system.values())
    terms = [_split(sp.csr_array(t.operator), part)[0] for t in (*system.conductance.terms, *system.capacity.terms)]
    return system, terms, _points(system, part)


def test_affine_coarse_levels_are_the_galerkin_levels_of_the_sum() -> None:
    """Pᵀ(Σ w_i A_i)P = Σ w_i PᵀA_iP: every level of the precomputed hierarchy equals the solver's own products."""
    _, terms, points = _terms()
    weights = np.random.default_rng(3).uniform(0.1, 10.0, len(terms))
    total = sp.csr_array(sum(w * t for w, t in zip(weights, terms, strict=True)))
    own = MultigridSolver(GridMatrix.from_points(total, points), rtol=RTOL, precision="double", coarsest=200)
    stored = MultigridSolver(AffineGrid.build(terms, points, coarsest=200).operator(weights), rtol=RTOL,
                             precision="double", coarsest=200)
    assert len(own.levels) == len(stored.levels) == 3
    for mine, theirs in zip(own.levels, stored.levels, strict=True):
        a, b = sp.csr_array(mine.matrix), sp.csr_array(theirs.matrix)
        assert abs(a - b).max() <= 1e-13 * abs(a).max()


def test_a_tolerance_below_the_rounding_floor_is_met_at_the_floor() -> None:
    """rtol = 1e-17 cannot be certified in float64: the solve stops within √27 ε ‖|A||x|‖ instead of raising."""
    _, terms, points = _terms((9, 10, 11))
    grid = AffineGrid.build(terms, points).operator([1.0] * len(terms))
    mg = MultigridSolver(grid, rtol=1e-17, precision="double")
    b = np.zeros(grid.n)
    b[grid.index] = 1.0
    x = mg.solve(b)
    a = grid.full()
    floor = FLOOR_FACTOR * np.finfo(float).eps * np.linalg.norm(abs(a) @ np.abs(x)) / np.linalg.norm(b)
    assert np.linalg.norm(b - a @ x) / np.linalg.norm(b) <= 1e-17 + floor
    assert mg.at_floor == 1
