"""Measurements: face-mean temperatures Y_ij at times t_i on observed faces j [Chavez2020, eq. 4, 12].

Measurements are an :class:`aromm.core.observables.Observables` table; a measurement file is its CSV (a header
``t,<face>,...``, times in s, temperatures in °C, one row per time, times strictly increasing).  Synthetic
measurements come from any forward model; the paper's measurements (§ 4.2) come from the *homogeneous
orthotropic* twin of the sample: one phase of conductivity diag(k̄_xx, k̄_yy, k̄_zz) (eq. 13) and capacity c̄ (eq. 14)
on the same box under the same scenario, see :func:`aromm.homogeneous_measurements`.  As in § 4.2, k̄ along
the loaded axis is best taken from the heterogeneous sample under that same scenario
(:func:`aromm.fluxmetric`): the twin then has the sample's steady face means exactly.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.forward_model import ForwardModel
from aromm.core.labchecks import PLAUSIBLE
from aromm.core.labcsv import read_lab_csv
from aromm.core.observables import Observables, write_csv

#: Measurements are the toolkit's one time-series table (times in s, one series per observed face, °C).
Measurements = Observables


def load_measurements(path: str | os.PathLike[str], faces: Iterable[str] | None = None, *,
                      columns: Mapping[str, str] | None = None, time_unit: str | None = None,
                      temperature_unit: str | None = None, plausible: tuple[float, float] = PLAUSIBLE) -> Measurements:
    """Read a measurement CSV: the toolkit's ``t,<face>,...`` file or a laboratory export (comments, units row,
    ``;`` and decimal comma, latin-1, missing cells: :func:`aromm.core.labcsv.read_lab_csv`, which also refuses
    sentinels, impossible temperatures and single outliers).  ``faces`` (e.g. ``model.outputs``) lists the allowed
    outputs, ``columns`` maps file columns onto them (``{"TC1": "z0"}``).  The conversions made are logged
    (``logging``, logger ``aromm.core.labcsv``); :func:`aromm.core.labcsv.read_lab_csv` returns them too.  Every problem
    raises InputError naming the file, line, column and what is allowed.
    """
    return read_lab_csv(path, faces, columns=columns, time_unit=time_unit, temperature_unit=temperature_unit,
                        plausible=plausible).table


def save_measurements(measurements: Measurements, path: str | os.PathLike[str]) -> None:
    """Write the ``t,<face>,...`` CSV atomically (:func:`aromm.core.observables.write_csv`)."""
    write_csv(measurements, path, "measurement file")


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
    chosen = tuple(faces) if faces is not None else obs.outputs
    missing = [f for f in chosen if f not in obs.mean_T]
    if missing:
        raise InputError(f"face(s) {', '.join(missing)} are not outputs of the model; "
                         f"allowed: {', '.join(obs.outputs)}")
    out = Measurements(np.asarray(obs.t, dtype=float), {f: np.asarray(obs.mean_T[f], dtype=float) for f in chosen},
                       source="simulated")
    if noise:
        if rng is None:
            raise InputError("noisy measurements need an rng (np.random.Generator)")
        out = out.with_noise(noise, rng)
    return out
