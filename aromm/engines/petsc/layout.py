"""Who owns what: contiguous row blocks, and z-slabs of a voxel grid.

The nodes of aromm.fem are numbered ``i + (nx+1) (j + (ny+1) k)``: a node plane ``k`` is a contiguous block
of ``(nx+1)(ny+1)`` rows.  A z-slab partition gives rank r the voxel layers ``layers[r] <= k < layers[r+1]``
and the node planes ``layers[r] <= k < layers[r+1]`` (the last rank also the top plane ``nz``): its rows are
one contiguous block of the global numbering.  A slab's voxels also touch its top plane, owned by the next
rank; those contributions are sent there once at assembly (aromm.engines.petsc.assembly).
"""

from __future__ import annotations

from dataclasses import dataclass

from aromm.core.errors import InputError


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


@dataclass(frozen=True)
class SlabLayout:
    """z-slab partition of a voxel grid of ``shape`` (nx, ny, nz) over ``size`` ranks."""

    shape: tuple[int, int, int]
    layers: tuple[int, ...]
    rank: int

    @classmethod
    def split(cls, shape: tuple[int, int, int], size: int, rank: int) -> SlabLayout:
        if shape[2] < size:
            raise InputError(f"the image has {shape[2]} z layers for {size} MPI ranks; every rank needs at least "
                             "one layer: run with fewer ranks")
        return cls(shape, even_split(shape[2], size), rank)

    @property
    def size(self) -> int:
        return len(self.layers) - 1

    @property
    def k0(self) -> int:
        return self.layers[self.rank]

    @property
    def k1(self) -> int:
        return self.layers[self.rank + 1]

    @property
    def plane(self) -> int:
        """Nodes per z plane."""
        return (self.shape[0] + 1) * (self.shape[1] + 1)

    @property
    def first(self) -> bool:
        return self.rank == 0

    @property
    def last(self) -> bool:
        return self.rank == self.size - 1

    @property
    def slab_shape(self) -> tuple[int, int, int]:
        return (self.shape[0], self.shape[1], self.k1 - self.k0)

    @property
    def rows(self) -> RowLayout:
        starts = [k * self.plane for k in self.layers[:-1]] + [(self.shape[2] + 1) * self.plane]
        return RowLayout(tuple(starts), self.rank)

    @property
    def offset(self) -> int:
        """Global number of the slab's first node."""
        return self.k0 * self.plane

    def faces(self) -> tuple[str, ...]:
        """Faces of the box that this slab touches: the four sides, z0 on the first rank, z1 on the last."""
        sides = ("x0", "x1", "y0", "y1")
        return sides + (("z0",) if self.first else ()) + (("z1",) if self.last else ())
