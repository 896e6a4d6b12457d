"""Assemble a voxel scene in cell-centred finite volumes (:mod:`aromm.fv.grid`) into a ThermalSystem.

The same affine system as the Q1 elements of :mod:`aromm.fem.voxel` [Chavez2020, eq. 3], with the two-point terms::

    K(p) = Σ_p k_p K_p + Σ_{p<q} (2 k_p k_q / (k_p + k_q)) K_pq + Σ_f h_f H_f,     C(p) = Σ_p c_p C_p,

``K_p`` the links inside phase p and its half-links to the face unknowns, ``K_pq`` the links between p and q (named
``K_p|q``, as the bonds of :mod:`aromm.dem.network`), ``C_p`` the voxel volumes (lumped: the face unknowns carry
no capacity).  Face loads, exchanges, fixed temperatures and face means are those of :mod:`aromm.core.vocabulary`
on the face unknowns.

An insulating phase (``k = 0``, steady scenes only: a voxel that conducts nothing but stores heat would need its
own history) carries no unknown.  In a steady scene the voxels that no conducting path joins to a face with a
fixed temperature or an exchange are removed too (their temperature is undetermined), with one log line giving
their volume fraction, as taufactor and PoreSpy do; a direction with no percolating path then carries no heat.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.system import Coefficient, Geometry, Term, ThermalSystem, TimeGrid
from aromm.core.vocabulary import (
    FACES,
    FaceSpec,
    PhaseSpec,
    check_image,
    face_terms,
    insulating,
    parameter_values,
    phase_index,
    phase_terms,
    system_of,
)
from aromm.fv.grid import AXES, VolumeGrid

log = logging.getLogger(__name__)


def connected(phase: npt.NDArray[np.int64], anchors: Sequence[str]) -> npt.NDArray[np.bool_]:
    """The voxels with a phase (``phase >= 0``) that face neighbours join to a voxel on one of the box faces
    ``anchors``.

    >>> p = np.array([0, -1, 0, 0]).reshape(4, 1, 1)
    >>> connected(p, ["x1"]).ravel().tolist()
    [False, False, True, True]
    """
    components = _components(phase >= 0)
    return np.isin(components, sorted(set().union(*(_touching(components, f) for f in anchors))))


def reachable(phase: npt.NDArray[np.int64], anchors: Sequence[str],
              joined: Sequence[str]) -> tuple[npt.NDArray[np.int64], bool]:
    """``phase`` with the voxels that no conducting path joins to a face of ``anchors`` set to −1 (logged, as
    :func:`pruned`), and whether one cluster touches every face of ``joined``: one labelling, none without an
    insulating voxel (the box is then one cluster).

    >>> p = np.array([0, -1, 0, 0]).reshape(4, 1, 1)
    >>> kept, joins = reachable(p, ["x0", "x1"], ["x0", "x1"])
    >>> kept.ravel().tolist(), joins
    ([0, -1, 0, 0], False)
    """
    if bool(np.all(phase >= 0)):
        return phase, True
    components = _components(phase >= 0)
    touching = [_touching(components, f) for f in joined]
    joins = bool(set.intersection(*touching)) if touching else True
    keep = np.isin(components, sorted(set().union(*(_touching(components, f) for f in anchors))))
    del components
    removed = int(np.count_nonzero((phase >= 0) & ~keep))
    if removed:
        log.info("finite volumes: %d voxels (%.4g %% of the volume) have no conducting path to a face with a fixed "
                 "temperature or an exchange (%s) and are left out", removed, 100.0 * removed / phase.size,
                 ", ".join(anchors))
    return np.where(keep, phase, -1), joins


def _components(conducting: npt.NDArray[np.bool_]) -> npt.NDArray[np.int32]:
    """Cluster labels (1, 2, …; 0 outside) of the ``conducting`` voxels joined by face neighbours (the two-point
    links)."""
    import scipy.ndimage as ndi  # ≈ 0.13 CPU s: only when an insulating phase is there to cut

    components, _ = ndi.label(conducting)  # the default structure: face neighbours
    return np.asarray(components, dtype=np.int32)


def _touching(components: npt.NDArray[np.int32], face: str) -> set[int]:
    """The clusters (labels > 0) with a voxel on ``face``."""
    axis, side = AXES.index(face[0]), (0 if face[1] == "0" else -1)
    return set(np.unique(np.take(components, side, axis=axis)).tolist()) - {0}


def winding_axes(conducting: npt.NDArray[np.bool_]) -> tuple[bool, bool, bool]:
    """Whether a cluster of ``conducting`` voxels, joined by face neighbours across the periodic box, winds around
    the box along each axis (a path that leaves through one face and comes back through the other): the axes along
    which the periodic cell conducts at all.

    Clusters of the box cut open are labelled, then joined by the links that wrap around it, each carrying the
    displacement of its crossing (e.g. +1 along x); a potential in Z³ is spread over that graph, and an edge that
    closes a loop with a displacement other than zero is a winding path along the axes where it is non-zero.

    >>> slab = np.zeros((4, 3, 3), dtype=bool)
    >>> slab[1] = True  # a plane across x, periodic along y and z
    >>> winding_axes(slab)
    (False, True, True)
    """
    components = _components(conducting)
    edges: dict[tuple[int, int], set[tuple[int, int, int]]] = {}
    winds = np.zeros(3, dtype=bool)
    for axis in range(3):
        if conducting.shape[axis] < 2:  # one voxel thick: every conducting voxel is its own neighbour across
            winds[axis] = bool(conducting.any())
            continue
        last, first = np.take(components, -1, axis=axis), np.take(components, 0, axis=axis)
        both = (last > 0) & (first > 0)
        step = (int(axis == 0), int(axis == 1), int(axis == 2))
        for u, v in set(zip(last[both].tolist(), first[both].tolist(), strict=True)):
            edges.setdefault((u, v), set()).add(step)
    neighbours: dict[int, list[tuple[int, npt.NDArray[np.int64]]]] = {}
    for (u, v), steps in edges.items():
        for step in steps:
            d = np.array(step)
            neighbours.setdefault(u, []).append((v, d))
            neighbours.setdefault(v, []).append((u, -d))
    potential: dict[int, npt.NDArray[np.int64]] = {}
    for root in neighbours:
        if root in potential:
            continue
        potential[root] = np.zeros(3, dtype=np.int64)
        stack = [root]
        while stack:
            u = stack.pop()
            for v, d in neighbours[u]:
                if v not in potential:
                    potential[v] = potential[u] + d
                    stack.append(v)
                else:
                    winds |= (potential[u] + d - potential[v]) != 0
    return bool(winds[0]), bool(winds[1]), bool(winds[2])


def conducting_phase(labels: np.ndarray, phases: Sequence[PhaseSpec]) -> npt.NDArray[np.int64]:
    """Each voxel's position in ``phases`` (:func:`aromm.core.vocabulary.phase_index`), −1 in an insulating phase
    (``k = 0``: no unknown there).

    >>> conducting_phase(np.array([0, 1, 0]).reshape(3, 1, 1), [PhaseSpec("a", 0, 0.0), PhaseSpec("b", 1, 2.0)]).ravel()
    array([-1,  1, -1])
    """
    phase = phase_index(labels, phases)
    phase[np.isin(labels, [ph.label for ph in phases if insulating(ph)])] = -1
    return phase


def pruned(phase: npt.NDArray[np.int64], boundary: Sequence[FaceSpec]) -> npt.NDArray[np.int64]:
    """``phase`` with the voxels of no path to a fixed-temperature or exchange face set to −1 (logged)."""
    anchors = [f.face for f in boundary if f.T is not None or f.h is not None]
    return reachable(phase, anchors, ())[0] if anchors else phase


def _interface_terms(grid: VolumeGrid, phases: Sequence[PhaseSpec], present: Sequence[int]) -> list[Term]:
    """The harmonic-mean links between every two phases that touch (axis by axis when either is orthotropic)."""
    terms = []
    for n, p in enumerate(present):
        for q in present[n + 1:]:
            a, b = phases[p], phases[q]
            by_axis = a.orthotropic or b.orthotropic
            for axis in AXES if by_axis else (None,):
                op = grid.interface(p, q, axis)
                if op is None:
                    continue
                names = tuple(f"{ph.name}.k_{axis}" if ph.orthotropic else f"{ph.name}.k" for ph in (a, b))
                suffix = f"_{axis}" if axis else ""
                terms.append(Term(f"K_{a.name}|{b.name}{suffix}", Coefficient(names, "harmonic"), op, "conduction"))
    return terms


def volume_grid(labels: np.ndarray, voxel_size: Sequence[float], phases: Sequence[PhaseSpec],
                boundary: Sequence[FaceSpec], outputs: Sequence[str], *, steady: bool) -> VolumeGrid:
    """The unknowns :func:`assemble_volumes` numbers: the conducting voxels (in a steady scene those a fixed
    temperature or an exchange reaches), and the faces that carry a condition or an output."""
    phase = conducting_phase(labels, phases)
    if steady:
        phase = pruned(phase, boundary)
    return VolumeGrid(phase, (float(voxel_size[0]), float(voxel_size[1]), float(voxel_size[2])),
                      unknown_faces(boundary, outputs))


def unknown_faces(boundary: Sequence[FaceSpec], outputs: Sequence[str]) -> tuple[str, ...]:
    """The box faces that carry face unknowns: those with a condition or an output, in FACES order."""
    return tuple(f for f in FACES if f in set(outputs) | {b.face for b in boundary})


def assemble_volumes(
    labels: np.ndarray,
    voxel_size: Sequence[float],
    phases: Sequence[PhaseSpec],
    boundary: Sequence[FaceSpec] = (),
    *,
    time: TimeGrid | None = None,
    initial_T: float = 0.0,
    outputs: Sequence[str] = (),
) -> ThermalSystem:
    """Assemble the voxel model in finite volumes into a :class:`ThermalSystem` with only the terms asked for.

    >>> import numpy as np
    >>> labels = np.array([0, 1]).reshape(2, 1, 1)
    >>> phases = [PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, 3.0)]
    >>> s = assemble_volumes(labels, (1.0,) * 3, phases, [FaceSpec("x0", T=1.0), FaceSpec("x1", T=0.0)])
    >>> s.conductance.names
    ('K_a', 'K_b', 'K_a|b')
    """
    labels = np.asarray(labels)
    check_image(labels, voxel_size, phases)
    voxel = (float(voxel_size[0]), float(voxel_size[1]), float(voxel_size[2]))
    cold = [ph.name for ph in phases if insulating(ph)]
    if cold and time is not None:
        raise InputError(f"phase {cold[0]!r}: k = 0 (insulating) is for steady scenes (homogenize, rev, simulate "
                         "without [time]); a transient needs every phase to conduct")
    grid = volume_grid(labels, voxel, phases, boundary, outputs, steady=time is None)
    present = sorted(set(np.unique(grid.cell_phase).tolist()))
    if not present:
        raise InputError("finite volumes: no voxel conducts heat to a face with a fixed temperature or an exchange "
                         "(every phase insulating, or no percolating path)")
    faces_terms, dirichlet = face_terms(grid, boundary)
    terms = phase_terms(grid, phases, present, transient=time is not None) + _interface_terms(grid, phases, present)
    return system_of(grid, terms + faces_terms, dirichlet, outputs=outputs, time=time,
                     parameters=parameter_values([phases[i] for i in present], boundary, initial_T, time is not None),
                     geometry=Geometry(grid.points(), np.arange(grid.n)[:, None], "vertex"))
