"""Measurements: face-mean temperatures Y_ij at times t_i on observed faces j (seed 001 eq. 4, 12).

A measurement file is a CSV with a header ``t,<face>,...`` (times in s, temperatures in degC),
one row per time, times strictly increasing.  Synthetic measurements come from any forward
model; the seed's measurements (§ 4.2) come from the *homogeneous orthotropic* twin of the
sample: one phase of conductivity diag(k̄_xx, k̄_yy, k̄_zz) (eq. 13) and capacity c̄ (eq. 14)
on the same box under the same scenario, see :func:`homogeneous_system`.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aromm.errors import InputError
from aromm.fem import FaceSpec, PhaseSpec, assemble_voxels
from aromm.model import ForwardModel
from aromm.system import FloatArray, ThermalSystem, TimeGrid

HOMOGENEOUS_PHASE = "homogeneous"


@dataclass(frozen=True)
class Measurements:
    """Times ``t`` (s, strictly increasing) and face-mean temperatures (degC) per observed face."""

    t: FloatArray
    values: Mapping[str, FloatArray]
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        where = f"{self.source}: " if self.source else ""
        if t.ndim != 1 or t.size == 0:
            raise InputError(f"{where}measurement times must be a non-empty 1-D array")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError(f"{where}measurement times must be finite and strictly increasing")
        if not self.values:
            raise InputError(f"{where}measurements need at least one face")
        for face, v in self.values.items():
            arr = np.asarray(v, dtype=float)
            if arr.shape != t.shape:
                raise InputError(f"{where}face {face!r} has {arr.size} values for {t.size} times")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{where}face {face!r} has non-finite values")

    @property
    def faces(self) -> tuple[str, ...]:
        return tuple(self.values)

    def as_array(self) -> FloatArray:
        """Values stacked as (len(t), n_faces) in the order of :attr:`faces`."""
        return np.column_stack([np.asarray(self.values[f], dtype=float) for f in self.faces])

    def with_noise(self, sigma: float, rng: np.random.Generator) -> Measurements:
        """Independent Gaussian noise of standard deviation ``sigma`` (degC) added to every value."""
        if not (math.isfinite(sigma) and sigma >= 0):
            raise InputError(f"noise sigma must be a finite non-negative temperature (degC), got {sigma!r}")
        noisy = {f: np.asarray(v, dtype=float) + sigma * rng.standard_normal(len(self.t))
                 for f, v in self.values.items()}
        return Measurements(np.asarray(self.t, dtype=float), noisy, self.source)

    def check_faces(self, allowed: Iterable[str]) -> None:
        """Refuse faces the model does not output (InputError naming them and the allowed ones)."""
        allowed = tuple(allowed)
        unknown = [f for f in self.faces if f not in allowed]
        if unknown:
            where = f"{self.source}: " if self.source else ""
            raise InputError(f"{where}face(s) {', '.join(unknown)} are not outputs of the model; "
                             f"allowed: {', '.join(allowed) or '(none)'}")


def load_measurements(path: str | os.PathLike[str], faces: Iterable[str] | None = None) -> Measurements:
    """Read a ``t,<face>,...`` CSV; ``faces`` (e.g. ``model.outputs``) lists the allowed face names.

    Every problem raises :class:`InputError` naming the file, the line and column, and what is allowed.
    """
    p = Path(path)
    allowed = tuple(faces) if faces is not None else None
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{p}: cannot read the measurement file ({err})") from None
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(text.splitlines())) if any(c.strip() for c in r)]
    if not rows:
        raise InputError(f"{p}: empty file; expected a header 't,<face>,...' and one row per time")
    header_line, header = rows[0]
    header = [h.strip() for h in header]
    if header[0] != "t" or len(header) < 2:
        raise InputError(f"{p} line {header_line}: the header must be 't,<face>,...' "
                         f"(time in s, then one column per face), got {','.join(header)!r}")
    names = header[1:]
    for col, name in enumerate(names, start=2):
        if not name:
            raise InputError(f"{p} line {header_line}, column {col}: empty face name")
        if names.count(name) > 1:
            raise InputError(f"{p} line {header_line}: face {name!r} appears twice")
        if allowed is not None and name not in allowed:
            raise InputError(f"{p} line {header_line}, column {col}: face {name!r} is not an output of the "
                             f"model; allowed: {', '.join(allowed) or '(none)'}")
    if len(rows) < 2:
        raise InputError(f"{p}: no data rows after the header")
    data = np.empty((len(rows) - 1, len(header)))
    for r, (line, row) in enumerate(rows[1:]):
        if len(row) != len(header):
            raise InputError(f"{p} line {line}: {len(row)} fields, the header has {len(header)}")
        for col, cell in enumerate(row):
            try:
                value = float(cell)
            except ValueError:
                raise InputError(f"{p} line {line}, column {header[col]!r}: {cell.strip()!r} is not a number") from None
            if not math.isfinite(value):
                raise InputError(f"{p} line {line}, column {header[col]!r}: {cell.strip()!r} is not finite")
            data[r, col] = value
        if data[r, 0] < 0:
            raise InputError(f"{p} line {line}: time t = {data[r, 0]:g} s is negative; times must be >= 0")
        if r > 0 and data[r, 0] <= data[r - 1, 0]:
            raise InputError(f"{p} line {line}: time t = {data[r, 0]:g} s does not increase "
                             f"(previous row t = {data[r - 1, 0]:g} s); times must be strictly increasing")
    values = {name: data[:, j + 1].copy() for j, name in enumerate(names)}
    return Measurements(data[:, 0].copy(), values, str(p))


def save_measurements(measurements: Measurements, path: str | os.PathLike[str]) -> None:
    """Write the ``t,<face>,...`` CSV (full float precision), atomically (temp file + rename)."""
    p = Path(path)
    arr = np.column_stack([np.asarray(measurements.t, dtype=float), measurements.as_array()])
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", dir=p.parent if str(p.parent) else ".")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(["t", *measurements.faces])
            w.writerows([[repr(float(v)) for v in row] for row in arr])
        os.replace(tmp, p)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def simulate_measurements(
    model: ForwardModel,
    params: Mapping[str, float] | None = None,
    times: npt.ArrayLike | None = None,
    *,
    faces: Sequence[str] | None = None,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> Measurements:
    """Measurements simulated by ``model`` at ``times`` (default: its time grid) on ``faces``.

    ``noise`` > 0 adds independent Gaussian noise of that standard deviation (degC), drawn from ``rng``.
    """
    obs = model.simulate(params, times)
    chosen = tuple(faces) if faces is not None else tuple(obs.mean_T)
    unknown = [f for f in chosen if f not in obs.mean_T]
    if unknown:
        raise InputError(f"face(s) {', '.join(unknown)} are not outputs of the model; "
                         f"allowed: {', '.join(obs.mean_T) or '(none)'}")
    out = Measurements(np.asarray(obs.t, dtype=float), {f: np.asarray(obs.mean_T[f], dtype=float) for f in chosen},
                       "simulated")
    if noise:
        if rng is None:
            raise InputError("noisy measurements need an rng (np.random.Generator)")
        out = out.with_noise(noise, rng)
    return out


def _diagonal(k_bar: npt.ArrayLike) -> tuple[float, float, float]:
    k = np.asarray(k_bar, dtype=float)
    if k.shape == (3, 3):
        off = k - np.diag(np.diag(k))
        if np.max(np.abs(off)) > 1e-3 * np.max(np.abs(np.diag(k))):
            raise InputError("the homogeneous model is orthotropic in the box axes: k̄ must be diagonal "
                             f"(off-diagonal terms <= 1e-3 of the diagonal), got {k.tolist()}")
        k = np.diag(k)
    if k.shape != (3,) or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise InputError(f"k̄ must be three positive conductivities (k_xx, k_yy, k_zz) in W/(m K), got {k.tolist()}")
    return float(k[0]), float(k[1]), float(k[2])


def homogeneous_system(
    shape: tuple[int, int, int],
    voxel_size: Sequence[float],
    k_bar: npt.ArrayLike,
    c_bar: float,
    boundary: Sequence[FaceSpec],
    *,
    time: TimeGrid | None,
    outputs: Sequence[str],
    initial_T: float = 0.0,
    perturbation: float = 0.0,
) -> ThermalSystem:
    """The homogeneous orthotropic twin (seed 001 eq. 1) of a ``shape`` voxel box.

    One phase ``"homogeneous"`` with k = diag(k̄) (eq. 13; a (3,) vector or a diagonal 3x3 tensor,
    W/(m K)) and c = c̄ (eq. 14, J/(m^3 K)), under the same ``boundary``, ``time`` and ``outputs``
    as the heterogeneous model.  ``perturbation`` multiplies every homogeneous property by
    ``1 + perturbation`` (seed 001 § 4.3 studies +2 %: ``perturbation=0.02``).
    """
    if not (math.isfinite(c_bar) and c_bar > 0):
        raise InputError(f"c̄ must be a positive volumetric heat capacity in J/(m^3 K), got {c_bar!r}")
    if not (math.isfinite(perturbation) and perturbation > -1):
        raise InputError(f"perturbation must be a finite fraction > -1, got {perturbation!r}")
    scale = 1.0 + perturbation
    kx, ky, kz = _diagonal(k_bar)
    phase = PhaseSpec(HOMOGENEOUS_PHASE, 0, k=(scale * kx, scale * ky, scale * kz), c=scale * float(c_bar))
    return assemble_voxels(np.zeros(shape, dtype=np.int32), voxel_size, [phase], boundary,
                           time=time, outputs=outputs, initial_T=initial_T)
