"""Grid transfers of the geometric multigrid, by strided slices into kept vectors.

The prolongation P is the tensor product of 1-D linear interpolations from the coarse nodes (every other fine
node, plus the end node of an odd box axis: :func:`aromm.linalg.multigrid.hierarchy.prolongation_1d`); the
restriction is Pᵀ [Trottenberg2001, § 2.3].  Along one axis with n fine elements, box or periodic,

    fine[2j] = coarse[j],   fine[2j + 1] = (coarse[j] + coarse[j + 1]) / 2   (j + 1 taken modulo the coarse nodes
    of a periodic axis),   fine[n] = coarse[last] for an odd box axis,

and Pᵀ gathers the same weights back.  Each pass writes into a vector the caller keeps: no sparse product, no
axis-moving copy, no fresh array (a fresh 34–68 MB array per pass was a fresh mapping for the kernel at 256³).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from aromm.core.system import FloatArray

Shape = tuple[int, int, int]


def coarse_nodes(elements: int, periodic: bool) -> int:
    """Coarse node count along an axis of ``elements`` fine elements (coarse elements (elements + 1) // 2)."""
    coarse = (elements + 1) // 2
    return coarse if periodic else coarse + 1


def _along(axis: int, index: slice | int) -> tuple[slice | int, ...]:
    return (slice(None),) * axis + (index,)


def interpolate_axis(coarse: FloatArray, fine: FloatArray, axis: int, elements: int, periodic: bool) -> None:
    """``fine`` ← P ``coarse`` along ``axis`` (other axes equal); ``elements`` fine elements on that axis."""
    m = elements // 2  # odd fine nodes between two coarse ones (not the end node of an odd box axis)
    nc = coarse.shape[axis]
    evens = fine[_along(axis, slice(0, None, 2))]
    evens[...] = coarse[_along(axis, slice(0, evens.shape[axis]))]
    odd = fine[_along(axis, slice(1, 2 * m, 2))]
    if m < nc:
        np.add(coarse[_along(axis, slice(0, m))], coarse[_along(axis, slice(1, m + 1))], out=odd)
    else:  # periodic, even: the last odd node lies between the last coarse node and the first
        np.add(coarse[_along(axis, slice(0, m - 1))], coarse[_along(axis, slice(1, m))],
               out=odd[_along(axis, slice(0, m - 1))])
        np.add(coarse[_along(axis, m - 1)], coarse[_along(axis, 0)], out=odd[_along(axis, m - 1)])
    odd *= 0.5
    if not periodic and elements % 2 == 1:
        fine[_along(axis, elements)] = coarse[_along(axis, nc - 1)]


def restrict_axis(fine: FloatArray, coarse: FloatArray, axis: int, elements: int, periodic: bool) -> None:
    """``coarse`` ← Pᵀ ``fine`` along ``axis`` (the adjoint of :func:`interpolate_axis`)."""
    m = elements // 2  # odd fine nodes between two coarse ones (not the end node of an odd box axis)
    nc = coarse.shape[axis]
    odd = fine[_along(axis, slice(1, 2 * m, 2))]
    coarse[...] = 0.0
    if m < nc:
        np.add(coarse[_along(axis, slice(1, m + 1))], odd, out=coarse[_along(axis, slice(1, m + 1))])
        np.add(coarse[_along(axis, slice(0, m))], odd, out=coarse[_along(axis, slice(0, m))])
    else:  # periodic, even: odd node m − 1 also feeds coarse node 0
        coarse[_along(axis, slice(1, m))] = odd[_along(axis, slice(0, m - 1))]
        coarse[_along(axis, 0)] = odd[_along(axis, m - 1)]
        np.add(coarse, odd, out=coarse)
    coarse *= 0.5
    evens = fine[_along(axis, slice(0, None, 2))]
    target = coarse[_along(axis, slice(0, evens.shape[axis]))]
    np.add(target, evens, out=target)
    if not periodic and elements % 2 == 1:
        end = coarse[_along(axis, nc - 1)]
        np.add(end, fine[_along(axis, elements)], out=end)


def transfer(v: FloatArray, elements: Shape, periodic: bool, restrict: bool,
             vector: Callable[[str, Shape, np.dtype], FloatArray]) -> FloatArray:
    """P v (coarse → fine node vector) or Pᵀ v (``restrict``: fine → coarse) on a grid of ``elements`` (z, y, x)
    fine elements; ``vector(name, shape, dtype)`` returns the caller's kept vector of that shape and v's dtype.
    The result is one of them (flat).

    >>> import numpy as np
    >>> keep = {}
    >>> def vector(name, shape, dtype):
    ...     return keep.setdefault(name, np.empty(shape, dtype))
    >>> ones = transfer(np.ones(3 * 3 * 3), (4, 4, 4), False, False, vector)  # 3³ coarse → 5³ fine nodes
    >>> bool(np.allclose(ones, 1.0)), ones.size
    (True, 125)
    """
    fine = tuple(e if periodic else e + 1 for e in elements)
    coarse = tuple(coarse_nodes(e, periodic) for e in elements)
    source, target = (fine, coarse) if restrict else (coarse, fine)
    name, apply = ("restrict", restrict_axis) if restrict else ("interpolate", interpolate_axis)
    a = v.reshape(source)
    for axis in range(3):
        out = vector(f"{name}{axis}", target[:axis + 1] + source[axis + 1:], v.dtype)  # type: ignore[arg-type]
        apply(a, out, axis, elements[axis], periodic)
        a = out
    return a.reshape(-1)
