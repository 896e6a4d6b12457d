"""Matrix-free Q1 conduction operator on a voxel grid, for the memory-lean steady solver.

The voxel model of :mod:`aromm.fem` (one trilinear hexahedron per voxel, conductivity constant per voxel)
is applied without assembling a matrix.  Per element, with the two-node "sum" S = u₁ + u₀ and "difference"
D = u₁ − u₀ along each axis (a Haar transform), the reference Q1 matrices are diagonal: along one axis of
length h the 1-D mass is h (a² + d²/12) with a = S/2 and the 1-D stiffness d²/h.  Hence the element energy

    uᵀ K_e u = Σ_c w_c (T_c u)²,   c ∈ {DSS, SDS, SSD, DDS, DSD, SDD, DDD}  (letters: x, y, z),

with w_DSS = g_x/16, w_DDS = (g_x + g_y)/48, w_DDD = (g_x + g_y + g_z)/144 (and permutations), where
g_x = k_x h_y h_z / h_x is the element's axial conductance.  A matrix-vector product is then 13 sums or
differences of shifted arrays, 7 products by the per-voxel weights and their adjoints: no matrix, and
memory of a few node arrays.  The same model is exposed as 27 numbers per element ("class values", the
entries of the symmetric 8×8 element matrix grouped by node pair per axis: {00, 01, 11}³), which the
Galerkin coarsening of :mod:`aromm.linalg.multigrid.hierarchy` maps to the coarse grids.

The capacity (mass) term of a per-voxel volumetric capacity c (J/(m³ K)) is diagonal in the same basis: the 1-D
mass h (S²/4 + D²/12) along each axis gives uᵀ C_e u = Σ_c w_c (T_c u)² over the eight combinations including
SSS, with w_SSS = c V/64, w_DSS = c V/192, w_DDS = c V/576, w_DDD = c V/1728 (V = h_x h_y h_z): so a shifted
operator K + s C [Chavez2020, eq. 3] costs one more pass.  A convection term ``h ∫_f φ_a φ_b`` on a face f
(``exchange``) is the Q1 face mass, a tensor product of two 1-D masses on the face's node plane.

Arrays are indexed (z, y, x) so that the flat node order is the one of :mod:`aromm.fem` (x fastest).  A
``periodic`` operator identifies the nodes of opposite faces (n nodes per axis instead of n + 1); a
``fixed`` face is a homogeneous Dirichlet plane: its rows and columns are replaced by the identity.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cached_property
from typing import cast

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.linalg.multigrid.q1_kernel import code_table, slab_product

COMBOS = ("DSS", "SDS", "SSD", "DDS", "DSD", "SDD", "DDD")  # letters: x, y, z
MASS_COMBOS = (*COMBOS, "SSS")  # with a capacity term
#: Per-voxel weights are kept while (combinations × voxels) fits: float32 (32 B/voxel) to 256³, float64 to ≈ 200³.
#: Above, the numpy product gathered them again (56 % of a float32 product at 256³, 2026-12-02); the compiled one
#: (q1_kernel) reads them by phase code.
WEIGHT_CACHE_BYTES = 1 << 30
SLAB_NODES = 1 << 16  # nodes per slab of the matrix-free product (0.5 MB per float64 array: cache-sized)
# 1-D reference matrices in the class basis {[0,0], [0,1], [1,1]} (lengths scaled out): stiffness, mass
STIFF_1D = np.array([1.0, -1.0, 1.0])
MASS_1D = np.array([1.0 / 3.0, 1.0 / 6.0, 1.0 / 3.0])


@dataclass(frozen=True, eq=False)
class VoxelOperator:
    """The Q1 conductance operator of a voxel image, matrix-free.

    ``phase``: (nz, ny, nx) integer index per voxel into ``conductivity`` ((n_phases, 3) rows k_x, k_y, k_z,
    W/(m K)); ``voxel_size`` (dx, dy, dz) in m.  ``periodic`` identifies opposite faces on every axis;
    ``fixed`` lists faces ("x0", ..., "z1") held at zero (box grids only).  ``capacity`` (n_phases,) adds the
    capacity term ``Σ_e c_e ∫ φ_a φ_b`` (J/(m³ K) times whatever factor, e.g. a Laplace shift s in 1/s);
    ``exchange`` adds ``h ∫_f φ_a φ_b`` on each listed (face, h in W/(m² K)) (box grids only).
    """

    phase: npt.NDArray[np.integer]
    conductivity: FloatArray
    voxel_size: tuple[float, float, float]
    periodic: bool = False
    fixed: tuple[str, ...] = ()
    capacity: FloatArray | None = None
    exchange: tuple[tuple[str, float], ...] = ()
    keep_weights: bool = True  # keep the gathered per-voxel weights while they fit WEIGHT_CACHE_BYTES
    compiled: bool = True  # uncached weights: aromm.linalg.multigrid.q1_kernel's product if numba imports
    _cache: dict[str, FloatArray] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if self.phase.ndim != 3 or min(self.phase.shape) < 1:
            raise InputError(f"voxel operator needs a 3-D image, got shape {self.phase.shape}")
        if self.periodic and (self.fixed or self.exchange):
            raise InputError("a periodic voxel operator has no faces to fix or to exchange heat through")

    @property
    def elements(self) -> tuple[int, int, int]:
        nz, ny, nx = self.phase.shape
        return (nz, ny, nx)

    @property
    def node_shape(self) -> tuple[int, int, int]:
        nz, ny, nx = self.elements
        return (nz, ny, nx) if self.periodic else (nz + 1, ny + 1, nx + 1)

    @property
    def n(self) -> int:
        return int(np.prod(self.node_shape))

    @cached_property
    def conductances(self) -> FloatArray:
        """(n_phases, 3) axial conductances g_x = k_x h_y h_z / h_x, g_y, g_z (W/K)."""
        dx, dy, dz = self.voxel_size
        return np.asarray(self.conductivity, dtype=float) * np.array([dy * dz / dx, dx * dz / dy, dx * dy / dz])

    @property
    def combos(self) -> tuple[str, ...]:
        return COMBOS if self.capacity is None else MASS_COMBOS

    @cached_property
    def weights(self) -> FloatArray:
        """(7, n_phases) weights w_c of the Haar form, in the order of COMBOS; (8, n_phases) with a capacity
        (MASS_COMBOS)."""
        gx, gy, gz = self.conductances.T
        out = np.stack([gx / 16, gy / 16, gz / 16, (gx + gy) / 48, (gx + gz) / 48, (gy + gz) / 48,
                        (gx + gy + gz) / 144])
        if self.capacity is None:
            return out
        m = np.asarray(self.capacity, dtype=float) * float(np.prod(self.voxel_size))
        mass = np.stack([m / 192, m / 192, m / 192, m / 576, m / 576, m / 576, m / 1728, m / 64])
        return np.vstack([out, np.zeros((1, out.shape[1]))]) + mass

    @cached_property
    def class_values(self) -> FloatArray:
        """(n_phases, 3, 3, 3) element matrix of each phase in class form, axes (z, y, x)."""
        out = np.zeros((len(self.conductances), 3, 3, 3))
        for axis in range(3):  # 0: x, 1: y, 2: z
            per_axis = [STIFF_1D if a == axis else MASS_1D for a in (2, 1, 0)]  # z, y, x factors
            out += self.conductances[:, axis, None, None, None] * np.einsum("i,j,k->ijk", *per_axis)
        if self.capacity is not None:
            volume = float(np.prod(self.voxel_size))
            out += (np.asarray(self.capacity, dtype=float) * volume)[:, None, None, None] * np.einsum(
                "i,j,k->ijk", MASS_1D, MASS_1D, MASS_1D)
        return out

    def exchange_classes(self, face: str, h: float) -> FloatArray:
        """(3, 3, 3) class values (axes z, y, x) of ``h ∫_f φ_a φ_b`` on the elements along ``face``."""
        axis = 2 - "xyz".index(face[0])  # class axis of the normal
        factors = []
        for a, length in zip(range(3), self.voxel_size[::-1], strict=True):
            factors.append((np.array([1.0, 0.0, 0.0]) if face[1] == "0" else np.array([0.0, 0.0, 1.0]))
                           if a == axis else MASS_1D * length)
        return float(h) * np.einsum("i,j,k->ijk", *factors)

    def fixed_planes(self) -> Iterator[tuple[int, int]]:
        """(array axis, index) of every fixed node plane."""
        for face in self.fixed:
            axis = 2 - "xyz".index(face[0])
            yield axis, (0 if face[1] == "0" else self.node_shape[axis] - 1)

    @cached_property
    def _padded_phase(self) -> npt.NDArray[np.integer]:
        """Phase index on the (nz, ny + 1, nx + 1) node layout; the extra row/column is a zero-weight phase."""
        nz, ny, nx = self.elements
        n_phases = len(self.conductances)
        out = np.full((nz, ny + 1, nx + 1), n_phases, dtype=np.min_scalar_type(n_phases))
        out[:, :ny, :nx] = self.phase
        return out

    def _weight_table(self, dtype: np.dtype) -> FloatArray:
        key = f"w{np.dtype(dtype).char}"
        if key not in self._cache:
            table = np.zeros((len(self.combos), len(self.conductances) + 1), dtype=dtype)
            table[:, :-1] = self.weights
            self._cache[key] = table
        return self._cache[key]

    def matvec(self, x: FloatArray, constrained: bool = True, out: npt.NDArray[np.floating] | None = None
               ) -> FloatArray:
        """K x for a flat node vector (n,) or a block of columns (n, k); ``constrained=False`` ignores ``fixed``
        (the free box operator).  The columns of a block share each slab's gathered weights.

        Computed in the vector's precision: float32 for a preconditioner, float64 otherwise.  ``out`` (of x's
        shape and that precision, contiguous by columns, not sharing memory with ``x``) receives K x: the multigrid's
        hot loop and the residual Gram's slabs reuse their arrays, since a fresh array above 32 MB is a fresh
        mapping that the kernel faults in page by page (at 256³ that was ≈ 40 % of a shifted solve,
        docs/one_machine.md).  A block whose columns are contiguous (a row slice of a Fortran-ordered basis) is
        read in place.
        """
        x = np.asarray(x)
        dtype = np.dtype(np.float32) if x.dtype == np.float32 else np.dtype(np.float64)
        u = _columns(x, dtype).reshape(-1, *self.node_shape)
        if out is None:
            y = np.zeros(u.shape, dtype=dtype)
        else:
            columns = out.T if out.ndim == 2 else out
            if (out.shape != (self.n, *x.shape[1:]) or out.dtype != dtype or not columns.flags.c_contiguous
                    or np.shares_memory(out, x)):
                raise InputError(f"voxel operator: out must be a separate {(self.n, *x.shape[1:])} {dtype} array "
                                 f"with contiguous columns, got {out.shape} {out.dtype}")
            y = columns.reshape(u.shape)
            y.fill(0.0)
        table = self._weight_table(dtype)
        mask = constrained and bool(self.fixed)
        kernel, codes = (slab_product() if self.compiled and not self._keeps(table) else None), code_table(table)
        for k0, k1 in self._slabs():
            weights = None
            for column, target in zip(u, y, strict=True):
                ext = self._gather(column, k0, k1, copy=mask)
                if mask:
                    self._zero_fixed(ext, k0, k1)
                if kernel is not None:  # one fused pass, the weights read by phase code (none kept)
                    result = self._workspace(dtype, ext.size, rows=1)[0, :ext.size].reshape(ext.shape)
                    kernel(ext, self._padded_phase[k0:k1], codes, result)
                else:
                    weights = self._slab_weights(table, k0, k1, _pass_size(ext.shape)) if weights is None else weights
                    result = self._apply(ext, weights)
                self._scatter(target, result, k0, k1)
        for column, target in zip(u, y, strict=True):
            self._faces(column, target, mask)
        if out is not None:
            return cast(FloatArray, out)
        return y.reshape(u.shape[0], -1).T if x.ndim == 2 else y.ravel()

    def _faces(self, u: FloatArray, y: FloatArray, mask: bool) -> None:
        """The face terms of one column (node arrays): convection on exchange faces, identity on fixed ones."""
        dtype = y.dtype
        for face, h in self.exchange:
            axis, index = self._face_plane(face)
            plane = np.array(u[_plane(axis, index)], dtype=float)
            if mask:
                for fixed_axis, fixed_index in self.fixed_planes():
                    if fixed_axis != axis:
                        plane[_plane(fixed_axis - (fixed_axis > axis), fixed_index)] = 0.0
            y[_plane(axis, index)] += (h * self._face_mass(plane, axis)).astype(dtype)
        if mask:
            for axis, index in self.fixed_planes():
                sl = _plane(axis, index)
                y[sl] = u[sl]

    def __matmul__(self, x: FloatArray) -> FloatArray:
        return self.matvec(x)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.n, self.n)

    def diagonal(self) -> FloatArray:
        """Diagonal of the constrained operator: Σ_e (g_x + g_y + g_z)/9 over the elements at each node."""
        per_phase = self.conductances.sum(axis=1) / 9.0
        if self.capacity is not None:
            per_phase = per_phase + np.asarray(self.capacity, dtype=float) * float(np.prod(self.voxel_size)) / 27.0
        d = self.spread(per_phase[self.phase], "SSS")
        for face, h in self.exchange:
            axis, index = self._face_plane(face)
            d.reshape(self.node_shape)[_plane(axis, index)] += h * self._face_mass(None, axis)
        for axis, index in self.fixed_planes():
            d.reshape(self.node_shape)[_plane(axis, index)] = 1.0
        return d

    def _face_plane(self, face: str) -> tuple[int, int]:
        axis = 2 - "xyz".index(face[0])
        return axis, (0 if face[1] == "0" else self.node_shape[axis] - 1)

    def _face_mass(self, plane: FloatArray | None, axis: int) -> FloatArray:
        """``∫_f φ_a φ_b`` times a node plane normal to array ``axis`` (its diagonal when ``plane`` is None)."""
        lengths = [h for a, h in enumerate(self.voxel_size[::-1]) if a != axis]
        shape = [s for a, s in enumerate(self.node_shape) if a != axis]
        if plane is None:
            d = [np.full(n, 2 * h / 3) for n, h in zip(shape, lengths, strict=True)]
            for v, h in zip(d, lengths, strict=True):
                v[[0, -1]] = h / 3
            return np.outer(d[0], d[1])
        out = _mass_rows(plane, lengths[0])
        return _mass_rows(out.T, lengths[1]).T

    def spread(self, element: FloatArray, pattern: str) -> FloatArray:
        """Adjoint of one Haar combination: nodes ← elements, e.g. ``"SSS"`` gives each element to its 8 nodes."""
        nz, ny, nx = self.elements
        row, plane = nx + 1, (ny + 1) * (nx + 1)
        padded = np.zeros((nz, ny + 1, nx + 1))
        padded[:, :ny, :nx] = element
        out = padded.reshape(-1)[:(nz - 1) * plane + (ny - 1) * row + nx]
        for letter, stride in zip(pattern[::-1], (plane, row, 1), strict=True):  # pattern is x, y, z
            wider = np.empty(out.size + stride)
            _adjoint(out if letter == "S" else None, out if letter == "D" else None, stride, wider, wider)
            out = wider
        return self._fold(out.reshape(nz + 1, ny + 1, nx + 1)).ravel()

    def _slabs(self) -> Iterator[tuple[int, int]]:
        nz, ny, nx = self.elements
        step = max(1, SLAB_NODES // ((ny + 1) * (nx + 1)))
        step = -(-nz // max(1, nz // step))  # equal slabs of SLAB_NODES to twice that: no thin last slab
        for k0 in range(0, nz, step):
            yield k0, min(nz, k0 + step)

    def _gather(self, u: np.ndarray, k0: int, k1: int, copy: bool) -> FloatArray:
        """Node planes k0..k1 of the elements [k0, k1), with the ghost row/column of a periodic grid."""
        if not self.periodic:
            return u[k0:k1 + 1].copy() if copy else u[k0:k1 + 1]
        nz, ny, nx = self.elements
        planes = np.arange(k0, k1 + 1) % nz
        ext = np.empty((k1 - k0 + 1, ny + 1, nx + 1), dtype=u.dtype)
        ext[:, :ny, :nx] = u[planes]
        ext[:, ny, :nx] = ext[:, 0, :nx]
        ext[:, :, nx] = ext[:, :, 0]
        return ext

    def _zero_fixed(self, ext: FloatArray, k0: int, k1: int) -> None:
        nz = self.elements[0]
        for axis, index in self.fixed_planes():
            if axis == 0:
                if index == 0 and k0 == 0:
                    ext[0] = 0.0
                elif index == nz and k1 == nz:
                    ext[-1] = 0.0
            else:
                ext[_plane(axis, index)] = 0.0

    def _apply(self, ext: FloatArray, weights: FloatArray) -> FloatArray:
        """Σ_c T_cᵀ w_c T_c on one slab (node planes k0..k1 → contributions to the same planes).

        Every pass is one contiguous operation on the flattened slab: a pair along y or z is a shift by a
        row or a plane.  Entries that straddle a row or plane end are garbage; their weight is zero.  All
        intermediates live in one preallocated workspace (no temporaries: at 40³ the page faults of fresh
        temporaries cost as much system time as the arithmetic).  The result is a view of the workspace.
        """
        planes, rows, cols = ext.shape
        u = ext.reshape(-1)
        row, plane = cols, rows * cols
        n = u.size
        m1, m2 = n - 1, n - 1 - row
        m = _pass_size(ext.shape)
        combos = len(self.combos)
        work = self._workspace(ext.dtype, n)
        sx, dx, ss, sd, ds, dd = (work[i, :m1 if i < 2 else m2] for i in range(6))
        _pair(u, 1, sx, dx)
        _pair(sx, row, ss, sd)
        _pair(dx, row, ds, dd)
        terms = work[6:6 + combos, :m]  # in the order of self.combos
        np.subtract(ss[plane:], ss[:-plane], out=terms[2])  # SSD
        if self.capacity is not None:
            np.add(ss[plane:], ss[:-plane], out=terms[7])  # SSS
        _pair(ds, plane, terms[0], terms[4])  # DSS, DSD
        _pair(sd, plane, terms[1], terms[5])  # SDS, SDD
        _pair(dd, plane, terms[3], terms[6])  # DDS, DDD
        terms *= weights
        scratch = work[14, :m1]
        g_ss, g_ds, g_sd, g_dd = ss, sd, ds, dd  # the pair rows are free again (length m + plane)
        _adjoint(terms[7] if self.capacity is not None else None, terms[2], plane, g_ss, scratch)
        _adjoint(terms[0], terms[4], plane, g_ds, scratch)
        _adjoint(terms[1], terms[5], plane, g_sd, scratch)
        _adjoint(terms[3], terms[6], plane, g_dd, scratch)
        h_s, h_d = sx, dx
        _adjoint(g_ss, g_sd, row, h_s, scratch)
        _adjoint(g_ds, g_dd, row, h_d, scratch)
        out = work[15, :n]
        _adjoint(h_s, h_d, 1, out, scratch)
        return out.reshape(planes, rows, cols)

    def _workspace(self, dtype: np.dtype, size: int, rows: int = 16) -> FloatArray:
        """(rows, ≥ size) slab scratch, kept per precision and row count (16 for numpy's passes, 1 for the kernel)."""
        key = f"work{np.dtype(dtype).char}{rows}"
        work = self._cache.get(key)
        if work is None or work.shape[1] < size:
            work = self._cache[key] = np.empty((rows, size), dtype=dtype)
        return work

    def _slab_weights(self, table: FloatArray, k0: int, k1: int, size: int) -> FloatArray:
        """(7, size) per-voxel weights of a slab, gathered once and kept when the grid is small."""
        key = f"{table.dtype.char}:{k0}"  # dtype.char: formatting a dtype costs ≈ 17 µs a product
        if key in self._cache:
            return self._cache[key]
        weights = np.take(table, self._padded_phase[k0:k1].reshape(-1)[:size], axis=1)
        if self._keeps(table):
            self._cache[key] = weights
        return weights

    def _keeps(self, table: FloatArray) -> bool:  # keep a slab's gathered weights (WEIGHT_CACHE_BYTES)
        return self.keep_weights and table.shape[0] * self._padded_phase.size * table.itemsize <= WEIGHT_CACHE_BYTES

    def _fold(self, out: FloatArray) -> FloatArray:
        """Ghost-extended node array → node array (periodic: ghosts added onto their twins)."""
        if not self.periodic:
            return out
        fold_ghosts(out, (1, 2))
        out[0] += out[-1]
        return out[:-1, :-1, :-1]

    def _scatter(self, y: FloatArray, out: FloatArray, k0: int, k1: int) -> None:
        if not self.periodic:
            y[k0:k1 + 1] += out
            return
        fold_ghosts(out, (1, 2))
        y[k0:k1] += out[:-1, :-1, :-1]
        y[k1 % self.elements[0]] += out[-1, :-1, :-1]

    def node_points(self) -> FloatArray:
        """(n, 3) node coordinates x, y, z (m) in the flat node order (for the nested-dissection ordering)."""
        z, y, x = np.meshgrid(*(np.arange(s) * h for s, h in zip(self.node_shape, self.voxel_size[::-1],
                                                                  strict=True)), indexing="ij")
        return np.column_stack([x.ravel(), y.ravel(), z.ravel()])


def _columns(x: np.ndarray, dtype: np.dtype) -> FloatArray:
    """The columns of ``x`` (n,) or (n, k) as rows of a (k, n) array in ``dtype``: a view when each column is
    contiguous (a row slice of a Fortran-ordered basis), else one C-ordered copy."""
    t = x.T
    if t.dtype == dtype and t.strides[-1] == t.itemsize:
        return cast(FloatArray, t)
    return cast(FloatArray, np.ascontiguousarray(t, dtype=dtype))


def _pass_size(shape: tuple[int, ...]) -> int:
    """Entries of the element-wise arrays of a slab of node planes ``shape``: its flat length less a row and a plane."""
    planes, rows, cols = shape
    return planes * rows * cols - 1 - cols - rows * cols


def fold_ghosts(a: FloatArray, axes: tuple[int, ...]) -> None:
    """Add the last (ghost) plane of ``a`` onto the first along each of ``axes`` (periodic identification)."""
    for axis in axes:
        a[_plane(axis, 0)] += a[_plane(axis, -1)]


def _mass_rows(a: FloatArray, h: float) -> FloatArray:
    """The 1-D linear-element mass h/6 tridiag(1, 4, 1) (ends 2) along the first axis of ``a``."""
    out = 4.0 * a
    out[[0, -1]] = 2.0 * a[[0, -1]]
    out[1:] += a[:-1]
    out[:-1] += a[1:]
    out *= h / 6
    return out


def _plane(axis: int, index: int) -> tuple[slice | int, ...]:
    return (slice(None),) * axis + (index,)


def _pair(a: FloatArray, stride: int, s: FloatArray, d: FloatArray) -> None:
    """(S a, D a) of a flat array into ``s`` and ``d``: a[i + stride] ± a[i]."""
    hi, lo = a[stride:], a[:-stride]
    np.add(hi, lo, out=s)
    np.subtract(hi, lo, out=d)


def _adjoint(s: FloatArray | None, d: FloatArray | None, stride: int, out: FloatArray, scratch: FloatArray) -> None:
    """``out`` ← Sᵀ s + Dᵀ d for flat arrays (length n → n + stride = ``out.size``; ``scratch`` ≥ n long)."""
    ref = s if s is not None else d
    assert ref is not None
    n = ref.size
    out[n:] = 0.0
    if s is None:
        assert d is not None
        np.negative(d, out=out[:n])
        out[stride:] += d
    elif d is None:
        out[:n] = s
        out[stride:] += s
    else:
        np.subtract(s, d, out=out[:n])
        total = scratch[:n]
        np.add(s, d, out=total)
        out[stride:] += total
