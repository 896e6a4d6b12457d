"""Homogenisation cell problems on a voxel image: periodic, uniform-flux and fixed-temperature boundaries.

Each boundary condition defines an *apparent* conductivity of the image; they differ by a boundary layer
whose weight falls like 1/n with the image size n [Huet1990] [Kanit2003]:

* ``periodic`` — T = G·x + T̃ with T̃ periodic, for the three unit gradients G = e_j.  The full tensor,
  off-diagonal terms included, is ``k_ij |Ω| = ∫ ∇T_i · k ∇T_j = δ_ij ⟨k_j⟩ |Ω| − b_i·T̃_j − b_j·T̃_i + T̃_iᵀ A T̃_j``
  with b_j = −Qᵀ A g_j the load of the gradient g_j = x_j (at the solution ``δ_ij ⟨k_j⟩ − b_i·T̃_j / |Ω|``; the
  symmetric energy form makes the algebraic error of every entry quadratic, aromm.homogenization.accuracy).
  It is the standard for a representative volume: exact for laminates in every direction, equal to the
  effective tensor of the periodic medium the image tiles, and between the two values below for a random image.
* ``flux`` — [Chavez2020, eq. 13]: uniform flux q into face i0, T = 0 on face i1, the others
  adiabatic; k_ii = q L_i / (T̄_i0 − T̄_i1).  A uniform-flux (static) face is a lower-bound type condition:
  its limit is below the effective value: on the sphere in a cube its Richardson values settle 0.53 % low,
  and along the layers of a laminate it never reaches the arithmetic mean (−35 % for half-and-half 1/10
  layers at every n; benchmarks/homogenize_resolution.py).
* ``temperature`` — T = 1 on i0, T = 0 on i1, the others adiabatic; k_ii = Q L_i / (A_i ΔT) from the heat
  flow, computed as the energy Tᵀ A T.  A mixed condition [HazanovHuet1994]: the fixed faces stiffen the
  boundary layer (the upper-bound type, kinematic, condition would fix T = G·x on *every* face) while the
  adiabatic sides soften it, so it is bounded by neither: exact for laminates and for mirror-symmetric
  cells (there equal to ``periodic``), measured 0.34 % / 0.12 % *below* periodic on the Gaussian random
  medium at 100³ / 200³.  On the sphere in a cube both converge from above, ≈ 50/n % once the voxel
  volume-fraction error is removed, and Richardson from (30³, 60³) is within 0.011 %.

``flux`` and ``temperature`` give the principal values along the image axes (off-diagonal zero).  Solvers:
``mg`` (geometric multigrid CG, :mod:`aromm.linalg.multigrid`; at 200³ 127 B/voxel all-in periodic, 120 with fixed
temperatures, docs/one_machine.md) or a direct/AMG method of
:mod:`aromm.linalg.direct` on the assembled operator; ``auto`` takes ``mg`` from ``MG_CROSSOVER_VOXELS`` (20³) voxels on
(benchmarks/homogenize_peers.py measures the crossover).  Images with a conductivity tensor or a fibre phase
(aromm.core.anisotropy) are solved on the assembled operator instead (:mod:`aromm.homogenization.anisotropic_cells`;
``mg`` becomes ``amg``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from aromm.core.choices import BOUNDARIES
from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.core.vocabulary import insulating
from aromm.fem.insulation import conducting_voxels, singular_insulation
from aromm.homogenization.accuracy import arithmetic_bound, harmonic_bound, periodic_energy_tolerances
from aromm.homogenization.anisotropic_cells import anisotropic, assembled_cell
from aromm.homogenization.fv_cells import fv_cell
from aromm.linalg.direct import DEFAULT_RTOL, METHODS, check_residual, factorize, resolve_method
from aromm.linalg.multigrid.hierarchy import CoarseLevel, assembled_matrix
from aromm.linalg.multigrid.operator import VoxelOperator
from aromm.linalg.multigrid.pcg import MultigridSolver, pinned
from aromm.linalg.multigrid.q1_kernel import slab_product
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

SOLVERS = METHODS
MG_CROSSOVER_VOXELS = 20**3  # multigrid beats CHOLMOD and pyamg SA from 16³–24³ on (homogenize_peers.py)
PROBE_FLUX = 1.0  # W/m^2; the problem is linear, so any value gives the same k
#: From this many voxels on, a cell problem's operator does not keep its gathered per-voxel weights (84 B/voxel in
#: float64 and float32) when the compiled product (numba, aromm.linalg.multigrid.q1_kernel) reads them by phase code
#: instead: the periodic tensor of a 200³ random medium (contrast 10, one thread, load 0.5-1.0, 2026-12-05) took
#: 222 B/voxel all-in against 294, in 26-32 CPU s against 30-34 (two runs each; 127 since the coarse levels lost
#: their CSR indices, docs/one_machine.md).  The Krylov reduction keeps them: its block products share each slab's
#: weights across columns.
KEEP_WEIGHTS_BELOW = 64**3


@dataclass
class CellResult:
    """Effective tensor (W/(m K)) with, per loaded direction, solver iterations and CPU/wall seconds."""

    k: FloatArray
    boundary: str
    method: str
    iterations: list[int] = field(default_factory=list)
    cpu_seconds: list[float] = field(default_factory=list)
    wall_seconds: list[float] = field(default_factory=list)
    setup_cpu_seconds: float = 0.0


def resolve_solver(method: str, voxels: int) -> str:
    """``auto`` → ``mg`` from MG_CROSSOVER_VOXELS voxels on, else the direct default of aromm.linalg.direct."""
    if method not in SOLVERS:
        raise InputError(f"unknown homogenisation solver {method!r}; allowed: {', '.join(SOLVERS)}")
    if method == "mg" or (method == "auto" and voxels >= MG_CROSSOVER_VOXELS):
        return "mg"
    return resolve_method(method)


def voxel_operator(scene: Scene, periodic: bool = False, fixed: tuple[str, ...] = ()) -> VoxelOperator:
    """The scene's conduction operator on its voxel grid (arrays in (z, y, x) order)."""
    image = _image(scene)
    labels = np.asarray(image.labels)
    known = {ph.label: i for i, ph in enumerate(scene.phases)}
    present = np.unique(labels)
    missing = sorted(set(present.tolist()) - set(known))
    if missing:
        raise InputError(f"{scene.where}image labels {missing} belong to no phase")
    lookup = np.zeros(int(present.max()) - int(present.min()) + 1, dtype=np.min_scalar_type(len(scene.phases)))
    for label in present.tolist():
        lookup[label - int(present.min())] = known[label]
    phase = np.ascontiguousarray(lookup[labels - int(present.min())].transpose(2, 1, 0))
    table = np.array([ph.k if isinstance(ph.k, tuple) else (ph.k,) * 3 for ph in scene.phases], dtype=float)
    keep = phase.size < KEEP_WEIGHTS_BELOW or slab_product() is None
    return VoxelOperator(phase, table, image.voxel_size, periodic=periodic, fixed=fixed, keep_weights=keep)


def _image(scene: Scene) -> VoxelGeometry:
    if not isinstance(scene.geometry, VoxelGeometry):
        raise InputError(f"{scene.where}the cell problems run on voxel images; this scene is a mesh")
    return scene.geometry


def effective_conductivity(scene: Scene, boundary: str = "periodic", method: str = "auto",
                           rtol: float = DEFAULT_RTOL, ktol: float | None = None, *,
                           axes: Sequence[int] = (0, 1, 2)) -> CellResult:
    """Apparent conductivity tensor of the scene's image under ``boundary`` (see the module docstring); the flux and
    temperature probes solve the ``axes`` asked only (the other entries stay 0).

    ``ktol`` (multigrid only; the direct methods are exact): stop each solve once the algebraic error of every
    tensor entry is at most ``ktol`` times a lower bound of the diagonal (aromm.homogenization.accuracy),
    instead of at the residual ``rtol``.
    """
    if boundary not in BOUNDARIES:
        raise InputError(f"unknown homogenisation boundary {boundary!r}; allowed: {', '.join(BOUNDARIES)}")
    if ktol is not None and not 0 < ktol < 1:
        raise InputError(f"homogenisation: ktol (relative error of k) must lie in (0, 1), got {ktol:g}")
    # fv solves stop at rtol, not ktol: CG's energy estimate, on which ktol rests, trailed the error of k by 4–40×
    # under fv's aggregation multigrid (contrast 1e3–1e4; its HS terms are not monotone there), so it would not hold
    if scene.discretisation == "fv":
        k, fv_name, cpus, walls = fv_cell(scene, boundary, method, rtol, MG_CROSSOVER_VOXELS, axes=axes)
        return CellResult(k, boundary, fv_name, cpu_seconds=cpus, wall_seconds=walls)
    name = resolve_solver(method, int(np.asarray(_image(scene).labels).size))
    refuse_singular_cells(scene, boundary, axes)
    if anisotropic(scene) or any(insulating(ph) for ph in scene.phases):
        # full or per-voxel tensors, or an insulating phase (the multigrid's smoother divides by every voxel's k):
        # the assembled operator (aromm.homogenization.anisotropic_cells)
        name = "amg" if name == "mg" else name
        return CellResult(assembled_cell(scene, boundary, name, rtol, axes), boundary, name)
    result = CellResult(np.zeros((3, 3)), boundary, name)
    if boundary == "periodic":
        _periodic(scene, name, rtol, result, ktol)
    else:
        free = voxel_operator(scene)
        shared: dict[str, list[CoarseLevel]] = {}  # one Galerkin hierarchy and weight cache for the three axes
        for axis in axes:
            _faces(scene, free, axis, boundary, method=name, rtol=rtol, result=result, ktol=ktol, shared=shared)
    return result


def refuse_singular_cells(scene: Scene, boundary: str, axes: Sequence[int]) -> None:
    """Refuse an insulating phase (k = 0) where a Q1 cell problem would be singular (:mod:`aromm.fem.insulation`):
    the periodic cell with the opposite faces identified; the fixed-temperature probe of each axis with its two
    faces fixed, the flux probe with the cooled face."""
    cold = [ph for ph in scene.phases if insulating(ph)]
    if not cold:
        return
    conducting = conducting_voxels(_image(scene).labels, scene.phases)
    probes = [("", (), True)] if boundary == "periodic" else [
        (f" along {'xyz'[a]}", (f"{'xyz'[a]}0", f"{'xyz'[a]}1") if boundary == "temperature" else (f"{'xyz'[a]}1",),
         False) for a in axes]
    for where, anchors, periodic in probes:
        why = singular_insulation(conducting, anchors, periodic=periodic)
        if why is not None:
            raise InputError(f"{scene.where}phase {cold[0].name!r}: k = 0 (insulating) in q1, the {boundary} cell "
                             f"problem{where}: {why}; the finite volumes remove such voxels (--discretisation fv)")


Solve = Callable[[FloatArray, "float | None"], FloatArray]  # (b, energy tolerance or None) → x


def _solver(op: VoxelOperator, method: str, rtol: float, result: CellResult,
            shared: dict[str, list[CoarseLevel]] | None = None) -> Solve:
    start = time.process_time()
    if method == "mg":
        mg = MultigridSolver(op, rtol=rtol, shared=shared)
        result.setup_cpu_seconds += time.process_time() - start

        def solve_mg(b: FloatArray, energy_tol: float | None) -> FloatArray:
            x = mg.solve(b, energy_tol=energy_tol)
            mg.release()  # the tensor's cross terms and the next load need the memory of CG's vectors
            result.iterations.append(mg.iterations[-1])
            return x

        return solve_mg
    matrix = assembled_matrix(op)
    factor = factorize(pinned(matrix) if op.periodic else matrix, method, rtol=rtol, points=op.node_points())
    result.setup_cpu_seconds += time.process_time() - start

    def solve_direct(b: FloatArray, energy_tol: float | None) -> FloatArray:  # exact: no energy tolerance
        rhs = b.copy()
        if op.periodic:
            rhs[0] = 0.0  # b sums to zero: node 0's equation follows from the others
        x = factor.solve(rhs, check=False)
        check_residual(matrix, x, b, rtol, method)  # the constrained (for periodic: singular) operator itself
        result.iterations.append(0)
        return x

    return solve_direct


def _timed(result: CellResult, solve: Solve, b: FloatArray, energy_tol: float | None = None) -> FloatArray:
    cpu, wall = time.process_time(), time.perf_counter()
    x = solve(b, energy_tol)
    result.cpu_seconds.append(time.process_time() - cpu)
    result.wall_seconds.append(time.perf_counter() - wall)
    return x


def _periodic(scene: Scene, method: str, rtol: float, result: CellResult, ktol: float | None) -> None:
    op = voxel_operator(scene, periodic=True)
    solve = _solver(op, method, rtol, result)
    volume = float(np.prod(scene.size))
    fractions = np.bincount(op.phase.ravel(), minlength=len(op.conductivity)) / op.phase.size

    def load(j: int) -> FloatArray:  # b_j = −Qᵀ A g_j, formed when needed: one float64 node vector held, not three
        return -op.spread(op.conductances[:, j][op.phase] * op.voxel_size[j] / 4.0, ("DSS", "SDS", "SSD")[j])

    energy = periodic_energy_tolerances(op, ktol, volume)
    earlier: list[FloatArray] = []  # T̃_i of the directions solved so far (float32: k_ij is stationary in them)
    for j in range(3):
        b = load(j)
        field_ = _timed(result, solve, b, energy[j])  # T̃_j
        result.k[j, j] = float(fractions @ op.conductivity[:, j]) - float(b @ field_) / volume
        if earlier:  # k_ij V = T_iᵀ A T_j = −b_iᵀT̃_j − b_jᵀT̃_i + T̃_iᵀ A T̃_j: error e_iᵀ A e_j, quadratic
            product = op.matvec(field_)
            for i, other in enumerate(earlier):
                value = (float(other @ product) - float(load(i) @ field_) - float(b @ other)) / volume
                result.k[i, j] = result.k[j, i] = value
            del product
        if j < 2:
            earlier.append(field_.astype(np.float32))
        del b, field_  # two float64 node vectors fewer during the next direction's solve


def _faces(scene: Scene, free: VoxelOperator, axis: int, boundary: str, *, method: str, rtol: float,
           result: CellResult, ktol: float | None, shared: dict[str, list[CoarseLevel]]) -> None:
    """One axis's cell problem on ``free`` (the image's box operator) with that axis's faces fixed."""
    name = "xyz"[axis]
    hot, cold = f"{name}0", f"{name}1"
    fixed = (hot, cold) if boundary == "temperature" else (cold,)
    op = replace(free, fixed=fixed)  # shares free's weight cache: the weights do not depend on the faces
    solve = _solver(op, method, rtol, result, shared)
    size = scene.size
    area = float(np.prod(size)) / size[axis]
    plane = (slice(None),) * (2 - axis) + (0,)
    if boundary == "temperature":
        # lift: the linear profile 1 → 0 between the fixed faces (the exact field of a homogeneous image), so the
        # correction x starts n times closer in energy than from a step on the hot face (one CG iteration fewer)
        nodes = op.node_shape[2 - axis]
        profile = 1.0 - np.arange(nodes) / (nodes - 1)
        lift = np.broadcast_to(profile.reshape((nodes,) + (1,) * axis), op.node_shape).copy()
        b = op.matvec(lift.ravel(), constrained=False)  # A l, negated below: neither l nor A l is held in the solve
        lift_energy = float(lift.ravel() @ b)  # lᵀA l
        del lift
        np.negative(b, out=b)
        b.reshape(op.node_shape)[plane] = 0.0
        for a, index in op.fixed_planes():
            b.reshape(op.node_shape)[(slice(None),) * a + (index,)] = 0.0
        energy = None if ktol is None else ktol * harmonic_bound(op, axis) * area / size[axis]
        x = _timed(result, solve, b, energy)
        # energy (l + x)ᵀA(l + x) = heat flow × ΔT (ΔT = 1 K); x vanishes on the fixed planes, where b does, so
        # xᵀA l = −bᵀx, and xᵀA x = bᵀx (Galerkin orthogonality of CG from zero, or the converged solve)
        energy = lift_energy - float(b @ x)
        result.k[axis, axis] = energy * size[axis] / area
        return
    weights = np.zeros(op.node_shape)
    weights[plane] = _face_weights(scene, axis)
    energy = None if ktol is None else ktol * PROBE_FLUX**2 * area * size[axis] / arithmetic_bound(op, axis)
    field_ = _timed(result, solve, PROBE_FLUX * weights.ravel(), energy)
    drop = float(weights.ravel() @ field_) / area  # T̄_i0 − T̄_i1, T̄_i1 = 0
    result.k[axis, axis] = PROBE_FLUX * size[axis] / drop


def _face_weights(scene: Scene, axis: int) -> FloatArray:
    """Nodal areas ∫ φ_n of the face normal to ``axis`` (array order: the two other axes, slowest first)."""
    image = _image(scene)
    others = [a for a in (2, 1, 0) if a != axis]  # z, y, x order
    ones = []
    for a in others:
        w = np.full(image.labels.shape[a] + 1, image.voxel_size[a])
        w[[0, -1]] *= 0.5
        ones.append(w)
    return np.outer(ones[0], ones[1])
