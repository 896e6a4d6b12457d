"""Who owns what: contiguous row blocks, and the 3-D box decomposition of a voxel grid.

A voxel image of ``(nx, ny, nz)`` voxels has ``(nx+1)(ny+1)(nz+1)`` nodes.  :class:`BoxLayout` cuts each axis
into ``m × n × p`` blocks of voxels (``cuts[a]``, sizes differing by at most one) over ``size = m n p`` ranks,
numbered ``rank = i + m (j + n k)`` for the block ``(i, j, k)``, as PETSc's DMDA numbers its processes.  Rank
``(i, j, k)`` reads and assembles the voxels of its box and owns the nodes ``cuts[a][i] <= c < cuts[a][i+1]``
on each axis (the last block of an axis also the top node ``n_a``): these are the node ownership ranges of a
DMDA of the node grid (aromm.engines.petsc.assembly creates it).  A box's voxels also touch its upper node
planes, owned by the neighbours above it; those contributions are sent to their owners once at assembly.

Rows are numbered as PETSc numbers a DMDA's global vectors: rank by rank, and inside a rank x fastest over
its owned nodes, so every rank's rows are one contiguous block (:class:`RowLayout`).  Nothing here imports
PETSc: the numbering is plain arithmetic, tested against the serial numbering of aromm.fem.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np

from aromm.core.errors import InputError

AXES = "xyz"


def even_split(count: int, parts: int) -> tuple[int, ...]:
    """Boundaries ``0 = b_0 <= … <= b_parts = count`` of ``parts`` blocks whose sizes differ by at most one."""
    base, extra = divmod(count, parts)
    bounds = [0]
    for r in range(parts):
        bounds.append(bounds[-1] + base + (1 if r < extra else 0))
    return tuple(bounds)


@dataclass(frozen=True)
class RowLayout:
    """Rows ``starts[r] <= i < starts[r+1]`` belong to rank r; this process is ``rank``."""

    starts: tuple[int, ...]
    rank: int

    @property
    def n(self) -> int:
        return self.starts[-1]

    @property
    def lo(self) -> int:
        return self.starts[self.rank]

    @property
    def hi(self) -> int:
        return self.starts[self.rank + 1]

    @property
    def local(self) -> int:
        return self.hi - self.lo

    @classmethod
    def even(cls, n: int, size: int, rank: int) -> RowLayout:
        return cls(even_split(n, size), rank)

    def interlaced(self, fields: int) -> RowLayout:
        """The rows of ``fields`` unknowns per row of this layout, interlaced (row ``fields i + f``: field f of
        row i), as a DMDA of ``fields`` degrees of freedom numbers them."""
        return RowLayout(tuple(fields * s for s in self.starts), self.rank)


def process_grid(shape: tuple[int, int, int], size: int,
                 fixed: tuple[int, int, int] = (0, 0, 0)) -> tuple[int, int, int]:
    """``(m, n, p)`` with ``m n p = size`` and at least one voxel per block on every axis, cutting the fewest
    node planes (least interface area ``(m−1) ny nz + (n−1) nx nz + (p−1) nx ny``); ties cut z first, then y
    (whole z layers per rank when z alone is cut, as a tomography stack is read).  ``fixed[a] > 0`` imposes
    the number of blocks along axis ``a``."""
    nx, ny, nz = shape
    best: tuple[tuple[int, int, int], tuple[int, int, int]] | None = None
    for m in range(1, size + 1):
        for n in range(1, size // m + 1):
            if size % (m * n):
                continue
            p = size // (m * n)
            if m > nx or n > ny or p > nz or any(0 < f != g for f, g in zip(fixed, (m, n, p), strict=True)):
                continue
            key = ((m - 1) * ny * nz + (n - 1) * nx * nz + (p - 1) * nx * ny, -p, -n)
            if best is None or key < best[0]:
                best = (key, (m, n, p))
    if best is None:
        imposed = "" if fixed == (0, 0, 0) else f" with {fixed} blocks along x, y, z (0: free)"
        raise InputError(f"an image of {nx}×{ny}×{nz} voxels cannot be cut into {size} boxes{imposed} of at least "
                         "one voxel on every axis: run with fewer ranks")
    return best[1]


@dataclass(frozen=True)
class BoxLayout:
    """Box decomposition of a voxel grid of ``shape`` (nx, ny, nz): ``cuts[a]`` are the voxel boundaries of the
    blocks along axis ``a``; this process is ``rank``."""

    shape: tuple[int, int, int]
    cuts: tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]]
    rank: int

    @classmethod
    def split(cls, shape: tuple[int, int, int], size: int, rank: int,
              processors: tuple[int, int, int] = (0, 0, 0)) -> BoxLayout:
        """Even blocks on the grid of :func:`process_grid` (``processors``: its ``fixed`` sizes)."""
        grid = process_grid(shape, size, processors)
        cuts = tuple(even_split(s, q) for s, q in zip(shape, grid, strict=True))
        return cls(shape, (cuts[0], cuts[1], cuts[2]), rank)

    @property
    def grid(self) -> tuple[int, int, int]:
        """Blocks along x, y, z."""
        return (len(self.cuts[0]) - 1, len(self.cuts[1]) - 1, len(self.cuts[2]) - 1)

    @property
    def size(self) -> int:
        return int(np.prod(self.grid))

    def coords(self, rank: int | None = None) -> tuple[int, int, int]:
        """Block ``(i, j, k)`` of ``rank`` (this process by default)."""
        r = self.rank if rank is None else rank
        m, n, _ = self.grid
        return (r % m, (r // m) % n, r // (m * n))

    @property
    def box(self) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
        """This rank's voxels ``lo <= c < hi`` on each axis."""
        ijk = self.coords()
        x, y, z = ((self.cuts[a][ijk[a]], self.cuts[a][ijk[a] + 1]) for a in range(3))
        return (x, y, z)

    @property
    def box_shape(self) -> tuple[int, int, int]:
        (x0, x1), (y0, y1), (z0, z1) = self.box
        return (x1 - x0, y1 - y0, z1 - z0)

    def ownership(self, axis: int) -> tuple[int, ...]:
        """Nodes owned by each block along ``axis`` (the DMDA's ownership ranges)."""
        sizes = list(np.diff(self.cuts[axis]).astype(int))
        sizes[-1] += 1
        return tuple(int(s) for s in sizes)

    def _block_rows(self) -> np.ndarray:
        """Rows owned by each block, indexed ``[i, j, k]``."""
        lx, ly, lz = (np.asarray(self.ownership(a)) for a in range(3))
        return lx[:, None, None] * ly[None, :, None] * lz[None, None, :]

    @property
    def rows(self) -> RowLayout:
        counts = [int(self._block_rows()[self.coords(r)]) for r in range(self.size)]
        return RowLayout(tuple(int(s) for s in np.concatenate([[0], np.cumsum(counts)])), self.rank)

    def faces(self, box: tuple[tuple[int, int], ...] | None = None) -> tuple[str, ...]:
        """Faces of the whole box that this rank's box (or ``box``, voxel ranges per axis) touches."""
        out = []
        for a, ((lo, hi), n) in enumerate(zip(self.box if box is None else box, self.shape, strict=True)):
            out += [f"{AXES[a]}0"] * (lo == 0) + [f"{AXES[a]}1"] * (hi == n)
        return tuple(out)

    def global_rows(self, lo: tuple[int, int, int], hi: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Global row and owner rank of the nodes ``lo[a] <= c <= hi[a]``, in the order aromm.fem numbers a box
        of ``hi − lo`` voxels (x fastest)."""
        first = np.concatenate([[0], np.cumsum([self._block_rows()[self.coords(r)] for r in range(self.size)])])
        start = np.empty(self.grid, dtype=np.int64)
        for r in range(self.size):
            start[self.coords(r)] = first[r]
        block, local, count = [], [], []
        for a in range(3):
            c = np.arange(lo[a], hi[a] + 1)
            q = np.minimum(np.searchsorted(self.cuts[a], c, side="right") - 1, self.grid[a] - 1)
            block.append(q)
            local.append(c - np.asarray(self.cuts[a])[q])
            count.append(np.asarray(self.ownership(a))[q])
        qx, qy, qz = np.ix_(*block)
        lx, ly, lz = np.ix_(*local)
        cx, cy, _ = np.ix_(*count)
        rows = start[qx, qy, qz] + lx + cx * (ly + cy * lz)
        m, n, _ = self.grid
        owner = qx + m * (qy + n * qz)
        kind = np.int32 if self.rows.n < 2**31 else np.int64  # PETSc's default index type where it suffices
        return rows.ravel(order="F").astype(kind), np.broadcast_to(owner, rows.shape).ravel(order="F")

    def box_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`global_rows` of this rank's box (its nodes, including the upper planes owned by neighbours)."""
        (x0, x1), (y0, y1), (z0, z1) = self.box
        return self.global_rows((x0, y0, z0), (x1, y1, z1))

    def blocks(self) -> list[tuple[int, int, int]]:
        """Every block ``(i, j, k)`` in rank order."""
        m, n, p = self.grid
        return [(i, j, k) for k, j, i in product(range(p), range(n), range(m))]
