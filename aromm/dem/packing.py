"""Dense random packings of polydisperse spheres for the DEM equivalent continuum [Hassan2019, § 2.1].

[Hassan2019, § 2.1] asks for a random, isotropic packing of slightly polydisperse spheres
(Gaussian radii, coefficient of variation 0.3) at a volume fraction phi close to 0.64.
Random sequential addition stops near phi = 0.38 and rigid walls keep the outer layer
loose, so (docs/notes/dem.md) the packing is made in a **periodic** cube:

1. radii ~ N(1, cv^2) (in units of the mean radius), truncated to ``1 +- 2.5 cv`` by
   redrawing, then the cube side chosen so that ``sum 4/3 pi r^3 = phi L^3``;
2. centres uniform in the cube (heavily overlapping);
3. the harmonic overlap energy ``U = 1/2 sum_{ij} (1 - d_ij / (r_i + r_j))^2`` over
   overlapping pairs (minimum-image distances) is minimised with FIRE (Bitzek et al.,
   PRL 97, 170201, 2006), neighbours from a ``scipy.spatial.cKDTree`` list with a skin,
   until the largest overlap is below ``tol`` of the contact distance.

At phi = 0.64 and cv = 0.3 the packing is below its jamming fraction, so overlaps vanish
and FIRE converges in a number of iterations roughly independent of N.  The periodic
packing is then cut (a non-periodic sub-box) or tiled (``reps^3`` periodic copies).
Lengths are in metres; the cube is ``[0, L)^3``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.spatial import cKDTree

from aromm.core.errors import InputError, NumericalError
from aromm.core.files import OutputKind, atomic_write, npz_with, read_npz
from aromm.core.system import FloatArray

TRUNCATION = 2.5  # radii are kept within mean +- TRUNCATION * sd
LOG_EVERY = 200  # FIRE iterations between two log lines
log = logging.getLogger(__name__)
ARRAYS = ("centers", "radii", "box", "periodic")
#: What ``aromm dem pack --out`` writes.
PACKING = OutputKind("packing (.npz written by aromm dem pack)", npz_with(*ARRAYS))


@dataclass(frozen=True)
class Packing:
    """Spheres ``centers`` (n, 3) and ``radii`` (n,) in m, in the box ``[lower, lower + box)``.

    ``periodic`` packings wrap across the box; cut ones do not (centres lie in the box,
    spheres may stick out of it).
    """

    centers: FloatArray
    radii: FloatArray
    box: FloatArray
    periodic: bool
    lower: FloatArray = field(default_factory=lambda: np.zeros(3))

    @property
    def n(self) -> int:
        return int(self.radii.size)

    @property
    def volumes(self) -> FloatArray:
        """Particle volumes 4/3 pi r^3 (m^3)."""
        return 4.0 / 3.0 * np.pi * self.radii**3

    @property
    def domain_volume(self) -> float:
        return float(np.prod(self.box))

    @property
    def volume_fraction(self) -> float:
        """phi = sum V_p / V_box [Hassan2019, eq. 1]; for a cut packing, spheres sticking out count whole."""
        return float(self.volumes.sum() / self.domain_volume)

    @property
    def mean_radius(self) -> float:
        return float(self.radii.mean())

    def save(self, path: str | Path) -> None:
        """Write a ``.npz`` (plain arrays, readable with ``allow_pickle=False``), atomically."""
        with atomic_write(path, "packing", binary=True) as fh:
            np.savez_compressed(fh, centers=self.centers, radii=self.radii, box=self.box, lower=self.lower,
                                periodic=np.array(self.periodic))

    def cut(self, lower: npt.ArrayLike, upper: npt.ArrayLike) -> Packing:
        """Non-periodic packing of the spheres whose centres lie in ``[lower, upper)`` (m).

        For a periodic packing the sub-box may reach past the periodic box (images are used).
        """
        lo = np.broadcast_to(np.asarray(lower, dtype=float), (3,)).copy()
        hi = np.broadcast_to(np.asarray(upper, dtype=float), (3,)).copy()
        if np.any(hi <= lo):
            raise InputError(f"cut: upper corner {hi.tolist()} must exceed lower corner {lo.tolist()}")
        centers, radii = self.centers, self.radii
        if self.periodic:
            first = np.floor((lo - self.lower) / self.box).astype(int)
            last = np.ceil((hi - self.lower) / self.box).astype(int)
            grids = np.meshgrid(*[np.arange(a, b) for a, b in zip(first, last, strict=True)], indexing="ij")
            shifts = np.stack(grids, -1).reshape(-1, 3) * self.box
            centers = (self.centers[None, :, :] + shifts[:, None, :]).reshape(-1, 3)
            radii = np.tile(self.radii, len(shifts))
        elif np.any(lo < self.lower) or np.any(hi > self.lower + self.box):
            raise InputError("cut: the sub-box must lie inside a non-periodic packing's box")
        inside = np.all((centers >= lo) & (centers < hi), axis=1)
        if not inside.any():
            raise InputError("cut: no sphere centre lies in the requested sub-box")
        return Packing(centers[inside], radii[inside], hi - lo, False, lo)

    def tile(self, reps: int) -> Packing:
        """Periodic packing of ``reps^3`` copies of this periodic one (exact: contacts are preserved)."""
        if not self.periodic:
            raise InputError("tile: only a periodic packing can be tiled")
        if reps < 1:
            raise InputError(f"tile: reps must be >= 1, got {reps}")
        shifts = np.stack(np.meshgrid(*[np.arange(reps)] * 3, indexing="ij"), -1).reshape(-1, 3) * self.box
        centers = (self.centers[None, :, :] + shifts[:, None, :]).reshape(-1, 3)
        return Packing(centers, np.tile(self.radii, len(shifts)), self.box * reps, True, self.lower.copy())

    def scaled(self, box: float) -> Packing:
        """The same packing scaled so that the box side along x is ``box`` (m)."""
        f = box / float(self.box[0])
        return Packing(self.lower * f + (self.centers - self.lower) * f, self.radii * f, self.box * f,
                       self.periodic, self.lower * f)


def load_packing(path: str | Path) -> Packing:
    """Read a packing written by :meth:`Packing.save` (``allow_pickle=False``)."""
    p = Path(path)
    data = read_npz(p, "packing (.npz written by aromm dem pack)", ARRAYS)
    try:
        centers, radii, box, lower = (np.asarray(data[k] if k in data else np.zeros(3), dtype=float)
                                      for k in ("centers", "radii", "box", "lower"))
        periodic = bool(data["periodic"])
    except (TypeError, ValueError) as err:
        raise InputError(f"{p}: not a packing file (centers, radii, box must be numbers, periodic a flag): "
                         f"{err}") from None
    if (centers.ndim != 2 or centers.shape[1] != 3 or radii.shape != (centers.shape[0],) or box.shape != (3,)
            or lower.shape != (3,)):
        raise InputError(f"{p}: centers must be (n, 3), radii (n,), box and lower (3,)")
    if not all(np.all(np.isfinite(a)) for a in (centers, radii, box, lower)):
        raise InputError(f"{p}: centers, radii, box and lower must be finite numbers (m)")
    if np.any(radii <= 0) or np.any(box <= 0):
        raise InputError(f"{p}: radii and box lengths must be positive")
    return Packing(centers, radii, box, periodic, lower)


def cubic_lattice(cells: int, spacing: float) -> Packing:
    """Periodic simple-cubic packing of ``cells^3`` equal spheres in contact (a reference network).

    Centres at ``(i + 1/2) a``, radii ``a / 2``: every sphere touches its 6 axis neighbours
    (phi = pi / 6).  Used as an exactly solvable network in tests.
    """
    if cells < 1 or spacing <= 0:
        raise InputError(f"cubic lattice: cells >= 1 and spacing > 0, got {cells}, {spacing}")
    idx = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 3).astype(float)
    return Packing((idx + 0.5) * spacing, np.full(cells**3, 0.5 * spacing), np.full(3, cells * spacing), True)


def gaussian_radii(n: int, cv: float, rng: np.random.Generator) -> FloatArray:
    """``n`` radii ~ N(1, cv^2), truncated to ``1 +- 2.5 cv`` by redrawing (mean radius ~ 1)."""
    if not 0.0 <= cv < 1.0 / TRUNCATION:
        raise InputError(f"coefficient of variation must be in [0, {1 / TRUNCATION:g}), got {cv}")
    r = rng.normal(1.0, cv, n)
    while True:
        bad = np.abs(r - 1.0) > TRUNCATION * cv
        if not bad.any():
            return r
        r[bad] = rng.normal(1.0, cv, int(bad.sum()))


@dataclass(frozen=True)
class FireSettings:
    """FIRE constants (Bitzek et al. 2006) in units of the mean radius; unit masses."""

    dt0: float = 0.1
    dt_max: float = 1.0
    n_min: int = 5
    f_inc: float = 1.1
    f_dec: float = 0.5
    alpha0: float = 0.1
    f_alpha: float = 0.99
    skin: float = 0.6  # mean radii: fewer list builds in the fast first iterations, few more pairs later
    max_iter: int = 20000


class _NeighbourList:
    """Pairs closer than ``r_i + r_j + skin`` (periodic), rebuilt when a sphere moved > skin / 2.

    At each build the pairs' periodic image offsets ``shift`` (x_i - x_j of the nearest images is
    ``x_i - x_j - shift`` until the next build: nobody moves by half a box in between), their contact
    distances ``sigma`` and the signed incidence ``(n, m)`` matrix (+1 at i, -1 at j) are stored, so that
    a force evaluation is a few vector operations and one sparse product.
    """

    def __init__(self, radii: FloatArray, side: float, skin: float) -> None:
        self.radii = radii
        self.side = side
        self.skin = skin
        self.r_max = float(radii.max())
        self.anchor = np.zeros((0, 3))
        self.i = np.zeros(0, dtype=np.int64)
        self.j = np.zeros(0, dtype=np.int64)
        self.shift = np.zeros((0, 3))
        self.sigma = np.zeros(0)
        self.incidence = sp.csr_array((radii.size, 0))
        self.builds = 0

    def stale(self, x: FloatArray) -> bool:
        """True before the first build and once a sphere moved more than skin / 2 since the last one."""
        if self.anchor.shape != x.shape:
            return True
        moved = x - self.anchor
        return bool(np.max(np.einsum("ij,ij->i", moved, moved)) >= (0.5 * self.skin) ** 2)

    def build(self, x: FloatArray, radii: FloatArray) -> None:
        """List the pairs of spheres ``x`` (radii ``radii``, in the order of ``x``) closer than sigma + skin."""
        self.radii = radii
        wrapped = np.mod(x, self.side)
        wrapped[wrapped >= self.side] = 0.0  # mod can round up to the side itself
        tree = cKDTree(wrapped, boxsize=self.side)
        pairs = tree.query_pairs(2.0 * self.r_max + self.skin, output_type="ndarray")
        i, j = pairs[:, 0], pairs[:, 1]
        raw = x[i] - x[j]
        shift = self.side * np.round(raw / self.side)
        d = raw - shift
        sigma = self.radii[i] + self.radii[j]
        keep = np.einsum("ij,ij->i", d, d) < (sigma + self.skin) ** 2
        self.i, self.j, self.shift, self.sigma = i[keep], j[keep], shift[keep], sigma[keep]
        m, n = self.i.size, x.shape[0]
        cols = np.arange(m)
        self.incidence = sp.csr_array((np.concatenate([np.ones(m), -np.ones(m)]),
                                       (np.concatenate([self.i, self.j]), np.concatenate([cols, cols]))),
                                      shape=(n, m))
        self.anchor = x.copy()
        self.builds += 1


def spatial_order(x: FloatArray, side: float) -> npt.NDArray[np.intp]:
    """Permutation sorting the points ``x`` of the periodic cube ``[0, side)^3`` along a Morton (Z-order) curve.

    Neighbours in space then sit near each other in memory, so the gathers of a force evaluation stay in
    cache: at 1.5e5 spheres in random order they cost several times more per pair than at 2e4.
    """
    cells = int(min(1024, max(1, np.ceil(side))))  # cells about one mean radius wide, 10 bits per axis
    c = np.clip((np.mod(x, side) * (cells / side)).astype(np.int64), 0, cells - 1)
    key = np.zeros(x.shape[0], dtype=np.int64)
    for axis in range(3):
        b = c[:, axis]
        b = (b | (b << 16)) & 0x030000FF
        b = (b | (b << 8)) & 0x0300F00F
        b = (b | (b << 4)) & 0x030C30C3
        b = (b | (b << 2)) & 0x09249249
        key |= b << axis
    return np.argsort(key, kind="stable")


def _overlap_forces(x: FloatArray, nl: _NeighbourList) -> tuple[FloatArray, float]:
    """Forces -grad U and the largest relative overlap max(1 - d/sigma) over the listed pairs."""
    d = x[nl.i]
    d -= x[nl.j]
    d -= nl.shift  # x_i - x_j, nearest image
    dist = np.sqrt(np.einsum("ij,ij->i", d, d))
    overlap = 1.0 - dist / nl.sigma
    largest = float(overlap.max(initial=0.0))
    if largest <= 0.0:
        return np.zeros_like(x), 0.0
    d *= (np.maximum(overlap, 0.0) / (nl.sigma * np.maximum(dist, 1e-12)))[:, None]  # force on i, along x_i - x_j
    return np.asarray(nl.incidence @ d), largest


def pack_spheres(
    n: int,
    rng: np.random.Generator,
    *,
    phi: float = 0.64,
    cv: float = 0.3,
    box: float = 1.0,
    tol: float = 1e-3,
    settings: FireSettings = FireSettings(),
    progress: Callable[[int, float], None] | None = None,
) -> Packing:
    """Periodic random packing of ``n`` spheres at volume fraction ``phi`` in a cube of side ``box`` (m).

    Radii are Gaussian with coefficient of variation ``cv`` [Hassan2019, § 2.1], truncated at
    +-2.5 sd.  FIRE stops when the largest overlap is below ``tol`` times the contact
    distance ``r_i + r_j``.  ``progress(iteration, max_overlap)`` is called every 50
    iterations.  Reproducible: the same ``rng`` state gives the same packing.
    """
    if n < 2:
        raise InputError(f"particles: need at least 2, got {n}")
    if not 0.0 < phi < 0.74:
        raise InputError(f"volume fraction phi must be in (0, 0.74), got {phi}")
    if box <= 0:
        raise InputError(f"box side must be positive, got {box}")
    radii = gaussian_radii(n, cv, rng)
    side = float((4.0 / 3.0 * np.pi * np.sum(radii**3) / phi) ** (1.0 / 3.0))
    x = rng.uniform(0.0, side, (n, 3))
    nl = _NeighbourList(radii, side, settings.skin)
    v = np.zeros_like(x)
    dt, alpha, n_pos = settings.dt0, settings.alpha0, 0
    max_overlap = np.inf
    for it in range(settings.max_iter):
        if nl.stale(x):  # renumber the spheres along a space-filling curve, then list the pairs
            order = spatial_order(x, side)
            x, v, radii = x[order], v[order], radii[order]
            nl.build(x, radii)
        f, max_overlap = _overlap_forces(x, nl)
        if progress is not None and it % 50 == 0:
            progress(it, max_overlap)
        if it % LOG_EVERY == 0:
            log.info("packing %d spheres: FIRE iteration %d, largest overlap %.2e (tol %g), %d neighbour-list builds",
                     n, it, max_overlap, tol, nl.builds)
        if max_overlap < tol:
            log.info("packing %d spheres: converged after %d FIRE iterations, %d neighbour-list builds",
                     n, it, nl.builds)
            break
        power = float(np.vdot(f, v))
        if power > 0.0:
            v_norm = np.sqrt(float(np.vdot(v, v)))
            f_norm = np.sqrt(float(np.vdot(f, f)))
            v = (1.0 - alpha) * v + alpha * (v_norm / max(f_norm, 1e-300)) * f
            n_pos += 1
            if n_pos > settings.n_min:
                dt = min(dt * settings.f_inc, settings.dt_max)
                alpha *= settings.f_alpha
        else:
            n_pos = 0
            dt *= settings.f_dec
            alpha = settings.alpha0
            v[:] = 0.0
        v += dt * f
        x += dt * v
    else:
        raise NumericalError(
            f"FIRE packing: largest overlap {max_overlap:.2e} still above tol {tol:g} after "
            f"{settings.max_iter} iterations (phi = {phi} may be above jamming for cv = {cv})"
        )
    x = np.mod(x, side)
    x[x >= side] = 0.0
    scale = box / side
    return Packing(x * scale, radii * scale, np.full(3, box), True, np.zeros(3))
