"""Near-neighbour bonds of a sphere packing [Hassan2019, § 2.1: mean coordination Z = 7.5].

At phi = 0.64 and cv = 0.3 true contacts give Z ~ 4.8 (docs/notes/dem.md), so a bond
joins two spheres whose *relative gap*

    g_pq = d_pq / (r_p + r_q) - 1

is below a threshold; the threshold is chosen so that the mean coordination
``Z = 2 m / n`` reaches the target (Z ~ 6 needs g < ~0.9 %, Z = 7.5 needs g < ~6 %).
A global threshold leaves a few particles with very few bonds, so each particle is then
given at least ``min_degree`` bonds (its nearest candidates by gap) and the graph is made
connected (each smaller component joined to the rest by its smallest-gap candidate).

For a cut (non-periodic) packing use the threshold of the periodic packing it was cut
from (``gap=`` argument): particles near the cut faces then simply lose the bonds that
crossed them, as in the sample of [Hassan2019].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.dem.packing import Packing

IntArray = npt.NDArray[np.int64]
Z_TOLERANCE = 0.01  # accepted |Z - target| after the repair
MAX_GAP = 0.5  # largest relative gap searched for the coordination threshold


@dataclass(frozen=True)
class Bonds:
    """Bond list: ``pairs`` (m, 2) with p < q, ``vectors`` x_q - x_p (m, 3) in m (nearest periodic image).

    ``gap_threshold`` is the relative gap below which pairs were bonded before the repair;
    ``added`` counts the bonds added to reach the minimum degree and connectivity.
    """

    pairs: IntArray
    vectors: FloatArray
    gap_threshold: float
    added: int = 0

    @property
    def m(self) -> int:
        return int(self.pairs.shape[0])

    @property
    def lengths(self) -> FloatArray:
        """Centre distances d_pq (m)."""
        return np.sqrt(np.einsum("ij,ij->i", self.vectors, self.vectors))

    @property
    def unit_vectors(self) -> FloatArray:
        """e_pq = (x_q - x_p) / d_pq [Hassan2019, eq. 9]."""
        return self.vectors / self.lengths[:, None]

    def degree(self, n: int) -> IntArray:
        return np.bincount(self.pairs.ravel(), minlength=n).astype(np.int64)

    def coordination(self, n: int) -> float:
        """Mean coordination number Z = 2 m / n."""
        return 2.0 * self.m / n


class _Neighbours:
    """KD-tree over the centres, with periodic images when the packing is periodic."""

    def __init__(self, packing: Packing) -> None:
        self.packing = packing
        x = packing.centers - packing.lower
        if packing.periodic:
            x = np.mod(x, packing.box)
            x[x >= packing.box] = 0.0
            self.tree = cKDTree(x, boxsize=packing.box)
        else:
            self.tree = cKDTree(x)
        self.x = x

    def vectors(self, i: IntArray, j: IntArray) -> FloatArray:
        """x_j - x_i, nearest periodic image."""
        vec = self.x[j] - self.x[i]
        if self.packing.periodic:
            vec -= self.packing.box * np.round(vec / self.packing.box)
        return vec

    def gaps(self, i: IntArray, j: IntArray) -> FloatArray:
        vec = self.vectors(i, j)
        r = self.packing.radii
        return np.sqrt(np.einsum("ij,ij->i", vec, vec)) / (r[i] + r[j]) - 1.0

    def within_gap(self, max_gap: float) -> tuple[IntArray, FloatArray]:
        """Pairs (p < q) with relative gap below ``max_gap``, sorted by gap, and their gaps."""
        cutoff = 2.0 * float(self.packing.radii.max()) * (1.0 + max_gap)
        if self.packing.periodic and cutoff >= 0.5 * float(self.packing.box.min()):
            raise InputError(
                f"packing too small for periodic bonds: box {self.packing.box.min():.3g} m is under twice "
                f"the search distance {cutoff:.3g} m; use more particles"
            )
        pairs = self.tree.query_pairs(cutoff, output_type="ndarray").astype(np.int64).reshape(-1, 2)
        gaps = self.gaps(pairs[:, 0], pairs[:, 1])
        keep = np.flatnonzero(gaps < max_gap)
        order = keep[np.argsort(gaps[keep], kind="stable")]
        return pairs[order], gaps[order]

    def nearest_by_gap(self, p: int, k: int) -> tuple[IntArray, FloatArray]:
        """The ``k`` centre-nearest other particles of ``p``, sorted by relative gap."""
        k = min(k + 1, self.packing.n)
        _, idx = self.tree.query(self.x[p], k=k)
        idx = np.asarray(idx, dtype=np.int64).ravel()
        idx = idx[idx != p]
        gaps = self.gaps(np.full(idx.size, p), idx)
        order = np.argsort(gaps, kind="stable")
        return idx[order], gaps[order]


def gap_for_coordination(packing: Packing, z: float) -> float:
    """Relative-gap threshold at which the near-neighbour graph reaches mean coordination ``z``."""
    if z <= 0:
        raise InputError(f"coordination number Z must be positive, got {z}")
    need = round(z * packing.n / 2.0)
    nb = _Neighbours(packing)
    max_gap = 0.05
    while True:
        _, gaps = nb.within_gap(max_gap)
        if gaps.size >= need + 1:
            return float(0.5 * (gaps[need - 1] + gaps[need]))
        if max_gap >= MAX_GAP:
            raise InputError(f"coordination Z = {z} is not reachable with gaps below {MAX_GAP:.0%}")
        max_gap = min(2.0 * max_gap, MAX_GAP)


def build_bonds(packing: Packing, z: float | None = 7.5, *, gap: float | None = None,
                min_degree: int = 3) -> Bonds:
    """Near-neighbour bonds: gap below the threshold giving coordination ``z`` (or the given ``gap``).

    Then every particle gets at least ``min_degree`` bonds (to its smallest-gap neighbours
    among the 16 nearest centres) and the graph is made connected [Hassan2019, § 2.1;
    docs/notes/dem.md].  Raises NumericalError if that is impossible.
    """
    if min_degree < 1:
        raise InputError(f"min_degree must be >= 1, got {min_degree}")
    nb = _Neighbours(packing)
    if gap is not None:
        return _bonds_below(nb, gap, min_degree)
    if z is None:
        raise InputError("build_bonds: give the coordination z or the gap threshold")
    # the repair adds bonds: lower the threshold until the final mean coordination is z
    target = z
    bonds = _bonds_below(nb, gap_for_coordination(packing, target), min_degree)
    for _ in range(6):
        error = bonds.coordination(packing.n) - z
        if abs(error) <= Z_TOLERANCE or target - error <= 0:
            break
        target -= error
        bonds = _bonds_below(nb, gap_for_coordination(packing, target), min_degree)
    return bonds


def _bonds_below(nb: _Neighbours, gap: float, min_degree: int) -> Bonds:
    pairs, _ = nb.within_gap(gap)
    extra = _raise_degree(nb, pairs, min_degree)
    pairs = np.vstack([pairs, extra]) if extra.size else pairs
    bridges = _connect(nb, pairs)
    added = len(extra) + len(bridges)
    if bridges.size:
        pairs = np.vstack([pairs, bridges])
    return Bonds(pairs, nb.vectors(pairs[:, 0], pairs[:, 1]), float(gap), added)


def _ordered(p: int, q: npt.ArrayLike) -> IntArray:
    q = np.atleast_1d(np.asarray(q, dtype=np.int64))
    return np.column_stack([np.minimum(p, q), np.maximum(p, q)])


def _raise_degree(nb: _Neighbours, pairs: IntArray, min_degree: int) -> IntArray:
    """Bonds to add so that every particle has at least ``min_degree`` (smallest gaps first)."""
    n = nb.packing.n
    degree = np.bincount(pairs.ravel(), minlength=n)
    existing = {(int(a), int(b)) for a, b in pairs[np.isin(pairs, np.flatnonzero(degree < min_degree))
                                                    .any(axis=1)]}
    added: list[tuple[int, int]] = []
    for p in np.flatnonzero(degree < min_degree):
        if degree[p] >= min_degree:  # raised meanwhile by a neighbour's repair
            continue
        near, _ = nb.nearest_by_gap(int(p), 16)
        for q in near:
            key = (int(min(p, q)), int(max(p, q)))
            if key in existing:
                continue
            existing.add(key)
            added.append(key)
            degree[p] += 1
            degree[q] += 1
            if degree[p] >= min_degree:
                break
        else:
            raise NumericalError(f"bond network: particle {p} has fewer than {min_degree} neighbours "
                                 "among its 16 nearest")
    return np.asarray(added, dtype=np.int64).reshape(-1, 2)


def _connect(nb: _Neighbours, pairs: IntArray) -> IntArray:
    """Bridges joining every smaller component to another one, smallest gap first."""
    n = nb.packing.n
    bridges: list[IntArray] = []
    for _ in range(n):
        allp = np.vstack([pairs, *bridges]) if bridges else pairs
        graph = sp.coo_array((np.ones(len(allp)), (allp[:, 0], allp[:, 1])), shape=(n, n))
        count, label = connected_components(graph, directed=False)
        if count == 1:
            break
        big = np.argmax(np.bincount(label))
        for comp in np.setdiff1d(np.unique(label), [big]):
            best: tuple[float, int, int] | None = None
            for p in np.flatnonzero(label == comp):
                near, gaps = nb.nearest_by_gap(int(p), 16)
                out = label[near] != comp
                if out.any() and (best is None or gaps[out][0] < best[0]):
                    best = (float(gaps[out][0]), int(p), int(near[out][0]))
            if best is None:
                raise NumericalError(f"bond network: a component of {np.sum(label == comp)} particles "
                                     "has no neighbour outside it among 16 nearest")
            bridges.append(_ordered(best[1], best[2]))
    return np.vstack(bridges) if bridges else np.zeros((0, 2), dtype=np.int64)


def coordination_table(packing: Packing, gaps: npt.ArrayLike) -> FloatArray:
    """Mean coordination Z of the plain gap-threshold graph for each threshold (no repair)."""
    g = np.asarray(gaps, dtype=float)
    _, sorted_gaps = _Neighbours(packing).within_gap(float(g.max()) * 1.0001 + 1e-12)
    return 2.0 * np.searchsorted(sorted_gaps, g, side="left") / packing.n
