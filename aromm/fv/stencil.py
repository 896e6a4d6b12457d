"""The matrix-free finite-volume operator: the 7-point conductance stencil of a voxel box, stored by its links.

The operator of :mod:`aromm.fv.grid` for the field's homogenisation problem (fixed temperatures on the two faces of
one axis, half a cell from the voxel centres, the other faces adiabatic), without assembling it::

    (A x)_i = Σ_{j ~ i} g_ij (x_i − x_j) + f_i x_i,

with ``g_ij`` the harmonic-mean conductance of the link (W/K) and ``f_i = 2 k_i A / d`` the half cell that joins a
voxel of a fixed face to that face (zero elsewhere).  The diagonal is never stored: every kernel sums it from the
links, so ``A`` is a conductance matrix exactly (a stored, rounded diagonal would add a spurious conductance to
ground of up to ``ε Σ g`` per cell, whose effect grows with the square of the cells along the path).

Storage: the links of each axis in float32 (``x``: shape ``(nx − 1, ny, nz)``, …), the two fixed planes' ``f`` in
float64, one ``alive`` byte per cell (a cell with no link and no fixed face: insulating, or removed).  Rounding the
links to float32 moves each by at most ``2⁻²⁴`` relatively; k̄ is non-decreasing in every link and homogeneous of
degree one in them, so it moves by at most ``2⁻²⁴ ≈ 6e-8`` relatively (:data:`LINK_ROUNDING`).

Coarse levels (:func:`coarsen`) aggregate 2 × 2 × 2 cells (the last one thinner on an odd axis) with piecewise-
constant transfers P; the Galerkin operator ``Pᵀ A P`` is again a 7-point stencil whose links are the sums of the
fine links that cross each coarse face and whose fixed-face terms are the sums of the fine ones [Notay2010].

A *periodic* stencil (:func:`periodic_stencil`, the periodic cell problem) has no fixed face and one more link per
row of every axis, from the last cell back to the first: ``links[a]`` then has the full length of axis ``a`` (link
``i`` joins cells ``i`` and ``i + 1 mod n``; an axis of one cell has none).  Its operator is singular, with one
constant per connected cluster in its null space.  Red–black colouring needs every periodic axis even (the last and
the first cell of an odd axis share a colour): :class:`~aromm.fv.multigrid.VolumeMultigrid` smooths a level with an
odd periodic axis by damped Jacobi instead.  2 × 2 × 2 aggregation of an even axis keeps the wrapped link as the
coarse one; on an odd axis the last cell is an aggregate alone, and the wrapped link joins it to the first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.system import FloatArray

#: Relative bound of the change of k̄ by storing the links in float32 (module docstring).
LINK_ROUNDING = 2.0**-24
Shape = tuple[int, int, int]


@dataclass(frozen=True, eq=False)
class Stencil:
    """Links ``links[a]`` (W/K, float32) along axis ``a``; ``low``/``high`` the fixed-face terms ``f`` (W/K) of the
    first and last planes along ``axis`` (``None``: no fixed face, a periodic-free Neumann box)."""

    links: tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32]]
    axis: int
    low: FloatArray
    high: FloatArray
    periodic: bool = False

    @property
    def shape(self) -> Shape:
        s = list(self.links[0].shape)
        s[0] += 0 if self.periodic else 1
        return (s[0], s[1], s[2])

    @property
    def cells(self) -> int:
        return int(np.prod(self.shape))

    def fixed(self) -> FloatArray:
        """``f`` as a full (sparse in content) array: the fixed-face terms on their planes, zero elsewhere."""
        f = np.zeros(self.shape)
        planes = np.moveaxis(f, self.axis, 0)  # a view: the fixed planes are its first and last
        planes[0] += self.low
        planes[-1] += self.high
        return f

    def alive(self) -> npt.NDArray[np.uint8]:
        """1 where a cell has a link or a fixed face, 0 where it carries no equation (kept at zero)."""
        weight = self.fixed() > 0
        for a, g in enumerate(self.links):
            cut = g > 0
            if self.periodic:
                weight |= cut | np.roll(cut, 1, axis=a)
                continue
            lo = [slice(None)] * 3
            hi = [slice(None)] * 3
            lo[a], hi[a] = slice(0, -1), slice(1, None)
            weight[tuple(lo)] |= cut
            weight[tuple(hi)] |= cut
        return weight.astype(np.uint8)

    def nbytes(self) -> int:
        return sum(g.nbytes for g in self.links) + self.low.nbytes + self.high.nbytes


def harmonic_links(k: FloatArray, voxel_size: tuple[float, float, float], axis: int) -> npt.NDArray[np.float32]:
    """``(A/d) · 2 k_i k_j / (k_i + k_j)`` between the cells of ``k`` (W/(m K), that axis' value) and their next
    neighbour along ``axis``; 0 where either cell is insulating.

    >>> harmonic_links(np.array([1.0, 3.0, 0.0]).reshape(3, 1, 1), (1.0, 1.0, 1.0), 0).ravel().tolist()
    [1.5, 0.0]
    """
    lo: list[slice] = [slice(None)] * 3
    hi: list[slice] = [slice(None)] * 3
    lo[axis], hi[axis] = slice(0, -1), slice(1, None)
    a, b = k[tuple(lo)], k[tuple(hi)]  # views: the cells before and after each link
    factor = float(np.prod(voxel_size)) / voxel_size[axis] ** 2
    s = a + b
    product = np.multiply(a, 2.0 * factor)
    product *= b
    out = np.zeros(a.shape, dtype=np.float32)
    np.divide(product, s, out=out, where=s > 0, casting="unsafe")
    return out


def conductance_stencil(k_axes: tuple[FloatArray, FloatArray, FloatArray], voxel_size: tuple[float, float, float],
                        axis: int) -> Stencil:
    """The stencil of fixed temperatures on the faces ``axis``0 and ``axis``1: ``k_axes[a]`` the conductivity of
    each cell along axis ``a`` (W/(m K); 0 for a cell without an equation)."""
    links = tuple(harmonic_links(k_axes[a], voxel_size, a) for a in range(3))
    factor = 2.0 * float(np.prod(voxel_size)) / voxel_size[axis] ** 2  # the half cell: 2 k A / d
    low = factor * np.take(k_axes[axis], 0, axis=axis)
    high = factor * np.take(k_axes[axis], -1, axis=axis)
    return Stencil((links[0], links[1], links[2]), axis, low, high)


def periodic_stencil(k_axes: tuple[FloatArray, FloatArray, FloatArray],
                     voxel_size: tuple[float, float, float]) -> Stencil:
    """The stencil of the periodic cell (module docstring): ``k_axes`` as :func:`conductance_stencil`'s.

    >>> st = periodic_stencil((np.ones((2, 3, 1)),) * 3, (1.0, 1.0, 1.0))
    >>> st.shape, [g.shape for g in st.links], float(st.links[2].max())
    ((2, 3, 1), [(2, 3, 1), (2, 3, 1), (2, 3, 1)], 0.0)
    """
    links = []
    for a, k in enumerate(k_axes):
        factor = float(np.prod(voxel_size)) / voxel_size[a] ** 2
        nxt = np.roll(k, -1, axis=a)
        s = k + nxt
        g = np.zeros(k.shape, dtype=np.float32)
        if k.shape[a] > 1:  # one cell along the axis: its wrapped link would join the cell to itself
            np.divide(2.0 * factor * k * nxt, s, out=g, where=s > 0, casting="unsafe")
        links.append(g)
    plane = np.zeros(k_axes[0].shape[1:])
    return Stencil((links[0], links[1], links[2]), 0, plane, plane.copy(), periodic=True)


def _pairs(a: npt.NDArray[np.floating], axes: tuple[int, ...]) -> FloatArray:
    """Sum of consecutive pairs along each of ``axes`` (a last single one on an odd length).

    >>> _pairs(np.arange(5.0).reshape(5, 1, 1), (0,)).ravel().tolist()
    [1.0, 5.0, 4.0]
    """
    for ax in axes:
        a = np.add.reduceat(a, np.arange(0, a.shape[ax], 2), axis=ax, dtype=np.float64)
    return np.asarray(a, dtype=np.float64)


def coarsen(stencil: Stencil) -> Stencil:
    """The Galerkin operator ``Pᵀ A P`` of 2 × 2 × 2 aggregation (module docstring)."""
    links = []
    for a, g in enumerate(stencil.links):
        picks = np.arange(1, g.shape[a], 2)  # fine links between two aggregates
        if stencil.periodic and g.shape[a] % 2 and g.shape[a] > 1:  # an odd periodic axis: its last cell, an
            picks = np.append(picks, g.shape[a] - 1)  # aggregate alone, joins the first by the wrapped link
        crossing = np.take(g, picks, axis=a)
        coarse = _pairs(crossing, tuple(b for b in range(3) if b != a)).astype(np.float32)
        if stencil.periodic and coarse.shape[a] == 1:
            coarse[...] = 0.0  # a single aggregate along the axis: its wrapped link joins it to itself
        links.append(coarse)
    low, high = _pairs(stencil.low, (0, 1)), _pairs(stencil.high, (0, 1))  # a plane's two axes
    return Stencil((links[0], links[1], links[2]), stencil.axis, low, high, stencil.periodic)


def assembled(stencil: Stencil) -> sp.csr_array:
    """The stencil as a sparse matrix (C order of the cells), for the coarsest level's direct solve; a cell
    without an equation gets a unit diagonal (its unknown stays zero)."""
    shape = stencil.shape
    index = np.arange(int(np.prod(shape))).reshape(shape)
    rows, cols, vals = [], [], []
    diagonal = stencil.fixed().ravel()
    for a, g in enumerate(stencil.links):
        count = g.shape[a]  # n − 1, or n with the wrapped links of a periodic stencil
        i = np.take(index, np.arange(count), axis=a).ravel()
        j = np.take(index, (np.arange(count) + 1) % shape[a], axis=a).ravel()
        w = g.ravel().astype(np.float64)
        rows += [i, j]
        cols += [j, i]
        vals += [-w, -w]
        np.add.at(diagonal, i, w)
        np.add.at(diagonal, j, w)
    dead = diagonal == 0
    diagonal[dead] = 1.0
    rows.append(index.ravel())
    cols.append(index.ravel())
    vals.append(diagonal)
    n = index.size
    return sp.csr_array(sp.coo_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                     shape=(n, n)))
