"""Where an insulating phase (k = 0) leaves the trilinear (Q1) conductance non-singular.

Q1 elements hold one temperature per node, shared by the (up to) eight voxels around it; a voxel of an insulating
phase adds no conductance.  The steady conductance matrix K is then singular exactly when

* a node touches no conducting voxel: its row of K is zero (inside an insulating region), or
* a cluster of conducting voxels reaches no face that fixes the temperature level (a fixed temperature or an
  exchange): its level is free.  Voxels that share a node, a corner included, are coupled through it, so the
  clusters are 26-connected; under periodic conditions every cluster adds a free constant, so the box must hold one
  (its level fixed by the pinned node), counted with the opposite faces identified.

The finite volumes remove such voxels (:func:`aromm.fv.volumes.pruned`); in Q1 a node cannot be removed without
changing its neighbours' elements, so the scene is refused, saying which condition fails (:func:`singular_insulation`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.vocabulary import PhaseSpec, insulating

BoolArray = npt.NDArray[np.bool_]
#: Voxels sharing a face, an edge or a corner share at least one node.
COUPLED = np.ones((3, 3, 3), dtype=bool)
AXES = "xyz"


def conducting_voxels(labels: npt.ArrayLike, phases: Sequence[PhaseSpec]) -> BoolArray:
    """The voxels of ``labels`` whose phase conducts (every phase but the insulating ones, ``k = 0``)."""
    return ~np.isin(np.asarray(labels), [ph.label for ph in phases if insulating(ph)])


def singular_insulation(conducting: BoolArray, anchors: Sequence[str] = (), *, periodic: bool = False) -> str | None:
    """Why the Q1 conductance of an image whose conducting voxels are ``conducting`` (x, y, z) is singular, or None
    when it is not (module docstring); ``anchors`` the faces ("x0", …, "z1") that fix the temperature level (ignored
    when ``periodic``).

    >>> walls = np.ones((4, 3, 3), dtype=bool); walls[2] = False  # one insulating layer across x
    >>> singular_insulation(walls, ("x0", "x1")) is None  # each side reaches its own fixed face
    True
    >>> singular_insulation(walls, ("x0",))[:63]  # the layer beyond the insulating one floats: a quarter of the box
    '25 % of the volume is conducting voxels that reach no face with'

    """
    from scipy import ndimage  # only where an insulating phase asks (not on every command's import path)

    conducting = np.asarray(conducting, dtype=bool)
    untouched = _untouched_nodes(conducting, periodic)
    if untouched:
        total = int(np.prod(conducting.shape)) if periodic else int(np.prod([n + 1 for n in conducting.shape]))
        return (f"{untouched} of the {total} nodes touch no conducting voxel (inside the insulating phase): their "
                "temperature is undetermined")
    if periodic:
        count = _periodic_clusters(conducting)
        if count > 1:
            return (f"the conducting voxels form {count} separate clusters across the periodic box (each adds a free "
                    "constant)")
        return None
    labels, count = ndimage.label(conducting, structure=COUPLED)
    anchored: set[int] = set()
    for face in anchors:
        layer = np.take(labels, 0 if face[1] == "0" else -1, axis=AXES.index(face[0]))
        anchored.update(int(v) for v in np.unique(layer) if v > 0)
    floating = sorted(set(range(1, count + 1)) - anchored)
    if not floating:
        return None
    share = float(np.isin(labels, floating).sum()) / labels.size
    return (f"{100 * share:.3g} % of the volume is conducting voxels that reach no face with a fixed temperature or "
            f"an exchange ({len(floating)} of {count} clusters): their temperature level is undetermined")


def _untouched_nodes(conducting: BoolArray, periodic: bool) -> int:
    """The nodes none of whose voxels conducts: node (i, j, k) sits between voxels i−1 and i along x (and so on)."""
    if periodic:
        touched = np.zeros_like(conducting)
        for shift in np.ndindex(2, 2, 2):
            touched |= np.roll(conducting, shift, axis=(0, 1, 2))
        return int((~touched).sum())
    padded = np.pad(conducting, 1)
    nx, ny, nz = conducting.shape
    touched = np.zeros((nx + 1, ny + 1, nz + 1), dtype=bool)
    for a, b, c in np.ndindex(2, 2, 2):
        touched |= padded[a:a + nx + 1, b:b + ny + 1, c:c + nz + 1]
    return int((~touched).sum())


def _periodic_clusters(conducting: BoolArray) -> int:
    """Clusters of 26-connected conducting voxels with opposite faces identified: the image padded by one wrapped
    layer is labelled, and the label of each padded position is joined with its voxel's label in the interior."""
    from scipy import ndimage
    from scipy.sparse.csgraph import connected_components

    padded = np.pad(conducting, 1, mode="wrap")
    labels, count = ndimage.label(padded, structure=COUPLED)
    if count <= 1:
        return int(count)
    own = np.pad(labels[1:-1, 1:-1, 1:-1], 1, mode="wrap")  # each padded position's voxel's interior label
    at = labels > 0
    graph = sp.coo_array((np.ones(int(at.sum())), (labels[at], own[at])), shape=(count + 1, count + 1))
    _, which = connected_components(graph, directed=False)
    return int(np.unique(which[1:]).size)
