"""Representative-volume (REV) study of a voxel image: how the apparent k̄ of sub-volumes settles with their size.

For sub-volumes (cubes) of growing edge e, cut at several positions of the image, the apparent conductivity tensor
is computed with periodic conditions (:mod:`aromm.homogenization.cell_problems`, geometric multigrid from 20³ voxels
on) and the mean capacity c̄ by volume average [Chavez2020, eq. 14].  Their *spread* at edge e is the relative standard
deviation over the positions, ``s(e) = max_i std_p(k_ii) / mean_p(k_ii)``: the statistical REV of [Kanit2003],
whose relative error on the mean of n sub-volumes is 2 s / √n.  The REV edge is the smallest studied edge from
which s stays below the tolerance; the recommended crop is the centred cube of that edge (``geometry.crop``).

A scanned image is not periodic: its apparent tensor depends on the boundary conditions, which bracket the
effective one, the boundary layer's weight falling like 1/e [Huet1990] [Kanit2003].  :func:`rev` therefore also
reports k̄ of the whole (largest) cube under uniform flux, periodic and fixed-temperature conditions, and their
relative spread ``(max − min) / periodic``: a spread above the tolerance says the volume is not yet representative
whatever the spread between positions.

Cost, measured with ``aromm rev`` on a 96³ spruce-like image (default edges 12…96, 9 positions, the three
boundary conditions; one thread, load average 12 on 2 cores): 83 CPU s, 3 min 45 s wall, 447 MB peak; the edges
of 72 and 48 voxels take most of it (29 and 15 CPU s).  The periodic solves scale about linearly with the voxels.
At 256³ (generated spruce-like image, default edges 32…256, ``--ktol 1e-4``, one thread): 382 CPU s, peak
3.95 GB (docs/guide/micro_ct.md).
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aromm.core.choices import BOUNDARIES, REV_TOLERANCE
from aromm.core.errors import InputError
from aromm.core.files import save_figure
from aromm.core.system import FloatArray
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.homogenization.properties import mean_capacity
from aromm.linalg.direct import DEFAULT_RTOL
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

if TYPE_CHECKING:
    from matplotlib.figure import Figure

log = logging.getLogger(__name__)
DEFAULT_FRACTIONS = (1 / 8, 1 / 4, 3 / 8, 1 / 2, 3 / 4, 1.0)  # default edges, as fractions of the smallest side
MIN_EDGE = 4  # voxels: below, a sub-volume holds too few voxels of each phase to mean anything


@dataclass(frozen=True)
class EdgeResult:
    """Sub-volumes of one edge (voxels): their origins, diagonal k̄ (n, 3) W/(m K), c̄ (n,) J/(m³ K) or None,
    the mean and relative spread of each diagonal term, and the CPU seconds spent."""

    edge: int
    origins: tuple[tuple[int, int, int], ...]
    k: FloatArray
    c: FloatArray | None
    cpu_seconds: float

    @property
    def mean(self) -> FloatArray:
        return np.asarray(self.k.mean(axis=0))

    @property
    def spread(self) -> float:
        """max over the axes of std/mean over the positions (0 for a single position)."""
        if len(self.origins) < 2:
            return 0.0
        return float(np.max(self.k.std(axis=0, ddof=1) / self.k.mean(axis=0)))


@dataclass(frozen=True)
class RevStudy:
    """The result of :func:`rev` (module docstring); ``method`` names the solvers used (e.g. ``"cholmod+mg"``: direct
    below 20³ voxels, multigrid above, with ``"auto"``)."""

    shape: tuple[int, int, int]
    voxel_size: tuple[float, float, float]
    tolerance: float
    method: str
    edges: tuple[EdgeResult, ...]
    rev_edge: int | None
    crop: tuple[tuple[int, int], ...] | None
    boundaries: dict[str, FloatArray]  # k̄ diagonal of the largest centred cube per boundary condition

    @property
    def boundary_spread(self) -> float | None:
        """(max − min) / periodic over the boundary conditions, worst axis (None when not computed)."""
        if len(self.boundaries) < 2:
            return None
        ks = np.stack(list(self.boundaries.values()))
        return float(np.max((ks.max(axis=0) - ks.min(axis=0)) / self.boundaries["periodic"]))

    @property
    def representative(self) -> bool:
        """Spread between positions and (when computed) between boundary conditions both within the tolerance."""
        spread = self.boundary_spread
        return self.rev_edge is not None and (spread is None or spread <= self.tolerance)

    def as_dict(self) -> dict[str, Any]:
        return {
            "shape": list(self.shape), "voxel_size": list(self.voxel_size), "tolerance": self.tolerance,
            "method": self.method,
            "edges": [{"edge": e.edge, "positions": len(e.origins), "k_mean": e.mean.tolist(), "spread": e.spread,
                       "k": e.k.tolist(), "c_mean": None if e.c is None else float(e.c.mean()),
                       "cpu_seconds": e.cpu_seconds} for e in self.edges],
            "rev_edge": self.rev_edge, "crop": None if self.crop is None else [list(c) for c in self.crop],
            "boundaries": {b: k.tolist() for b, k in self.boundaries.items()},
            "boundary_spread": self.boundary_spread, "representative": self.representative,
        }

    def __str__(self) -> str:
        lines = [f"REV study of a {'×'.join(map(str, self.shape))} image, periodic k̄ by {self.method}, "
                 f"tolerance {self.tolerance:.3g}",
                 "  edge  positions       k̄_xx        k̄_yy        k̄_zz   spread        c̄   CPU s"]
        for e in self.edges:
            c = f"{float(e.c.mean()):9.4g}" if e.c is not None else "        —"
            lines.append(f"{e.edge:6d} {len(e.origins):10d} " + " ".join(f"{v:11.5g}" for v in e.mean)
                         + f" {e.spread:8.2%} {c} {e.cpu_seconds:7.2f}")
        if self.rev_edge is None:
            lines.append(f"spread above {self.tolerance:.3g} up to the largest edge: the image is not representative")
        else:
            lines.append(f"REV edge {self.rev_edge} voxels; recommended crop = {[list(c) for c in self.crop or ()]}")
        for b, k in self.boundaries.items():
            lines.append(f"{b:>11} boundary, largest cube: k̄ diag " + " ".join(f"{v:.5g}" for v in k))
        spread = self.boundary_spread
        if spread is not None:
            verdict = ("within the tolerance" if spread <= self.tolerance
                       else "above the tolerance: the volume is not yet representative")
            lines.append(f"spread between boundary conditions {spread:.2%}: {verdict}")
        return "\n".join(lines)


def default_edges(shape: Sequence[int]) -> tuple[int, ...]:
    """Edges at DEFAULT_FRACTIONS of the smallest side, at least MIN_EDGE voxels.

    >>> default_edges((64, 64, 48))
    (6, 12, 18, 24, 36, 48)
    """
    side = min(shape)
    return tuple(sorted({max(MIN_EDGE, round(f * side)) for f in DEFAULT_FRACTIONS if round(f * side) <= side}))


def origins(shape: Sequence[int], edge: int, positions: int) -> tuple[tuple[int, int, int], ...]:
    """Up to ``positions`` origins of cubes of ``edge`` voxels: the centred cube first, then the 8 corners, then
    the remaining positions of a 3 × 3 × 3 grid (distinct origins only).

    >>> origins((10, 10, 10), 10, 9), len(origins((10, 10, 10), 4, 9))
    (((0, 0, 0),), 9)
    """
    spans = [n - edge for n in shape]
    centre = tuple(s // 2 for s in spans)
    corners = itertools.product(*[(0, s) for s in spans])
    grid = itertools.product(*[(0, s // 2, s) for s in spans])
    out: list[tuple[int, int, int]] = []
    for o in itertools.chain([centre], corners, grid):
        o3 = (int(o[0]), int(o[1]), int(o[2]))
        if o3 not in out:
            out.append(o3)
    return tuple(out[:positions])


def sub_scene(scene: Scene, origin: Sequence[int], edge: int) -> Scene:
    """The scene's material on the cube of ``edge`` voxels at ``origin`` (no faces, outputs or sensors)."""
    image = scene.geometry
    assert isinstance(image, VoxelGeometry)
    box = tuple(slice(o, o + edge) for o in origin)
    cube = VoxelGeometry(np.ascontiguousarray(image.labels[box]), image.voxel_size)
    present = set(np.unique(cube.labels).tolist())
    phases = tuple(ph for ph in scene.phases if ph.label in present)
    return replace(scene.with_boundary((), ()), geometry=cube, phases=phases, segmentation=None)


def rev(scene: Scene, edges: Sequence[int] | None = None, *, positions: int = 9,
        tolerance: float = REV_TOLERANCE, method: str = "auto", rtol: float = DEFAULT_RTOL,
        ktol: float | None = None, boundaries: bool = True) -> RevStudy:
    """REV study of the scene's voxel image (module docstring).

    ``edges``: cube edges in voxels (default :func:`default_edges`); ``positions``: sub-volumes per edge (≥ 1);
    ``tolerance``: relative spread that makes a volume representative; ``method``: solver of the periodic cell
    problems (``"auto"``: multigrid from 20³ voxels); ``boundaries``: also solve the largest centred cube under
    ``flux`` and ``temperature`` conditions; ``rtol`` / ``ktol``: stopping of each multigrid solve
    (:func:`aromm.homogenization.cell_problems.effective_conductivity`).  Inputs are checked before any solve
    (InputError).
    """
    image = scene.geometry
    if not isinstance(image, VoxelGeometry):
        raise InputError(f"{scene.where}the REV study cuts sub-volumes of a voxel image; this scene is a mesh")
    shape = image.shape
    chosen = tuple(default_edges(shape) if edges is None else edges)
    bad = [e for e in chosen if isinstance(e, bool) or not isinstance(e, int | np.integer) or not 1 <= e <= min(shape)]
    if not chosen or bad:
        raise InputError(f"{scene.where}REV edges must be integers in 1..{min(shape)} (the image's smallest side), "
                         f"got {list(chosen)}")
    if isinstance(positions, bool) or not isinstance(positions, int) or positions < 1:
        raise InputError(f"REV positions must be a positive integer, got {positions!r}")
    if not (isinstance(tolerance, float | int) and 0 < tolerance < 1):
        raise InputError(f"REV tolerance must be a relative spread in (0, 1), got {tolerance!r}")
    capacities = all(ph.c is not None for ph in scene.phases)
    results = []
    used: set[str] = set()
    for edge in sorted(set(int(e) for e in chosen)):
        start = time.process_time()
        where = origins(shape, edge, positions)
        ks, cs = [], []
        for origin in where:
            sub = sub_scene(scene, origin, edge)
            cell = effective_conductivity(sub, "periodic", method, rtol, ktol)
            used.add(cell.method)
            ks.append(np.diag(cell.k))
            if capacities:
                cs.append(mean_capacity(sub))
        results.append(EdgeResult(edge, where, np.array(ks), np.array(cs) if capacities else None,
                                  time.process_time() - start))
        log.info("REV: edge %d, %d positions, spread %.3g, %.1f CPU s", edge, len(where), results[-1].spread,
                 results[-1].cpu_seconds)
    rev_edge = _rev_edge(results, tolerance)
    crop = None
    if rev_edge is not None:
        centre = origins(shape, rev_edge, 1)[0]
        crop = tuple((o, o + rev_edge) for o in centre)
    largest = results[-1]
    cube = sub_scene(scene, largest.origins[0], largest.edge)
    by_boundary = {"periodic": largest.k[0]}
    if boundaries:
        by_boundary = {b: np.diag(effective_conductivity(cube, b, method, rtol, ktol).k) if b != "periodic"
                       else largest.k[0] for b in BOUNDARIES}
    return RevStudy(shape, image.voxel_size, float(tolerance), "+".join(sorted(used)), tuple(results), rev_edge,
                    crop, by_boundary)


def _rev_edge(results: Sequence[EdgeResult], tolerance: float) -> int | None:
    """The smallest edge from which every larger edge's spread is within the tolerance, among the edges with two
    positions or more (one position, e.g. the whole image, measures no spread); None if the largest's is not."""
    edge = None
    for result in reversed([r for r in results if len(r.origins) > 1]):
        if result.spread > tolerance:
            break
        edge = result.edge
    return edge


def rev_figure(study: RevStudy) -> Figure:
    """Diagonal k̄ of every sub-volume (dots) and their mean ± standard deviation against the edge; the REV edge
    dashed; the k̄ of the largest cube under each boundary condition at the right."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    edges = np.array([e.edge for e in study.edges], dtype=float)
    for i, axis in enumerate("xyz"):
        colour = f"C{i}"
        for e in study.edges:
            ax.plot(np.full(len(e.origins), e.edge), e.k[:, i], ".", color=colour, alpha=0.4)
        std = np.array([e.k[:, i].std(ddof=1) if len(e.origins) > 1 else 0.0 for e in study.edges])
        ax.errorbar(edges, [e.mean[i] for e in study.edges], yerr=std, color=colour, capsize=3,
                    label=f"k̄_{axis}{axis} (periodic)")
        for marker, (b, k) in zip("v^s", study.boundaries.items(), strict=False):
            ax.plot(edges[-1] * 1.04, k[i], marker, color=colour, label=f"{b}, largest cube" if i == 0 else None)
    if study.rev_edge is not None:
        ax.axvline(study.rev_edge, color="0.3", ls="--", label=f"REV edge {study.rev_edge}")
    ax.set_xlabel("sub-volume edge (voxels)")
    ax.set_ylabel("apparent k̄ (W/(m K))")
    ax.set_title(f"REV study, tolerance {study.tolerance:.3g} on std/mean over positions", fontsize=9)
    ax.legend(fontsize=7)
    return fig


def save_rev_plot(study: RevStudy, path: str | Path, dpi: int = 120) -> Path:
    """Write :func:`rev_figure` to ``path`` atomically (format from the suffix)."""
    return save_figure(rev_figure(study), path, "REV plot", dpi)
