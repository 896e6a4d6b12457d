"""Measurements: face-mean temperatures Y_ij at times t_i on observed faces j (seed 001 eq. 4, 12).

A measurement file is a CSV with a header ``t,<face>,...`` (times in s, temperatures in degC),
one row per time, times strictly increasing.  Synthetic measurements come from any forward
model; the seed's measurements (§ 4.2) come from the *homogeneous orthotropic* twin of the
sample: one phase of conductivity diag(k̄_xx, k̄_yy, k̄_zz) (eq. 13) and capacity c̄ (eq. 14)
on the same box under the same scenario, see :func:`homogeneous_measurements`.  As in § 4.2, k̄ along
the loaded axis is best taken from the heterogeneous sample under that same scenario
(:func:`aromm.homogenize.fluxmetric`): the twin then has the sample's steady face means exactly.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aromm.errors import InputError
from aromm.files import atomic_write
from aromm.homogenize import homogeneous_twin
from aromm.model import ForwardModel
from aromm.scene import Scene, assemble
from aromm.solve import simulate
from aromm.system import FloatArray


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
        _check_faces(self.faces, tuple(allowed), f"{self.source}: " if self.source else "")


def _check_faces(faces: Iterable[str], allowed: tuple[str, ...], where: str = "") -> None:
    unknown = [f for f in faces if f not in allowed]
    if unknown:
        raise InputError(f"{where}face(s) {', '.join(unknown)} are not outputs of the model; "
                         f"allowed: {', '.join(allowed) or '(none)'}")


def load_measurements(path: str | os.PathLike[str], faces: Iterable[str] | None = None) -> Measurements:
    """Read a ``t,<face>,...`` CSV; ``faces`` (e.g. ``model.outputs``) lists the allowed face names.

    Every problem raises :class:`InputError` naming the file, the line and column, and what is allowed.
    """
    p = Path(path)
    allowed = tuple(faces) if faces is not None else None
    try:
        text = p.read_text(encoding="utf-8-sig")  # tolerates the byte-order mark of spreadsheet exports
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
    """Write the ``t,<face>,...`` CSV (full float precision), atomically (:func:`aromm.files.atomic_write`).

    Missing parent folders are created; a path that cannot be written raises InputError naming it.
    """
    arr = np.column_stack([np.asarray(measurements.t, dtype=float), measurements.as_array()])
    with atomic_write(path, "measurement file") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["t", *measurements.faces])
        w.writerows([[repr(float(v)) for v in row] for row in arr])


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
    _check_faces(chosen, tuple(obs.mean_T))
    out = Measurements(np.asarray(obs.t, dtype=float), {f: np.asarray(obs.mean_T[f], dtype=float) for f in chosen},
                       "simulated")
    if noise:
        if rng is None:
            raise InputError("noisy measurements need an rng (np.random.Generator)")
        out = out.with_noise(noise, rng)
    return out


def homogeneous_measurements(scene: Scene, k: npt.ArrayLike, c: float, *, perturbation: float = 0.0,
                             method: str = "auto") -> Measurements:
    """Face means of the homogeneous orthotropic twin of ``scene`` (seed 001 eq. 1, § 4.2).

    ``k`` is the effective conductivity (W/(m K)): a 3x3 tensor (``aromm.homogenize``) or, for a
    scenario loaded along one axis, the scalar ``aromm.homogenize.fluxmetric(scene).k`` (seed 001
    § 4.2; the unloaded axes carry no heat); ``c`` the mean capacity (J/(m^3 K);
    ``aromm.mean_capacity(scene)``, eq. 14).  Every homogeneous property is multiplied by
    ``1 + perturbation`` (§ 4.3 studies +2 %: 0.02).  The twin (``aromm.homogeneous_twin``) has the
    scene's box, face conditions, time grid and outputs; it is simulated by the full model
    with the linear solver ``method``.
    """
    if scene.time is None:
        raise InputError(f"{scene.where}measurements need a transient scene ([time] with end and dt)")
    if not (math.isfinite(perturbation) and perturbation > -1):
        raise InputError(f"perturbation must be a finite fraction > -1, got {perturbation!r}")
    scale = 1.0 + perturbation
    twin = homogeneous_twin(scene, scale * np.asarray(k, dtype=float), scale * float(c))
    obs = simulate(assemble(twin), method=method)
    return Measurements(np.asarray(obs.t, dtype=float), {f: np.asarray(v, dtype=float) for f, v in obs.mean_T.items()},
                        f"homogeneous twin of {scene.path or 'scene'}")
