"""Physical checks of laboratory values before any work: sentinels, absolute zero, a plausible range, outliers,
and data in kelvin against a scene in °C.

A logger writes a code where it has no reading: ``-9999`` or ``9999`` (open thermocouple), ``9.9e37`` (overflow,
the IEEE-754 "not a number" of some loggers), ``±inf``, ``nan``.  Read as temperatures they would be fitted
(issue 23: an overflow code gave a "standard error" of 1.9e37 °C).  :func:`check_values` refuses, naming the
file, line and column:

* a non-finite value and a sentinel (:data:`SENTINELS`, or any magnitude ≥ :data:`OVERFLOW`);
* a temperature below absolute zero (−273.15 °C, 0 K);
* a temperature outside the plausible range (default :data:`PLAUSIBLE`, °C; ``--plausible LOW:HIGH``);
* a single outlier: a value that leaves both its neighbours in the same direction by more than
  :data:`SPIKE_RATIO` times the change between those neighbours and than the column's robust noise level
  (1.4826 × the median absolute deviation of its differences, at least the logger's resolution).  Heat
  diffuses: a measured temperature cannot jump for one sample and come back; such a value is a reading error,
  named, never fitted.

:func:`kelvin_suspect` compares unstated data with the scene's initial temperature before anything is built.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray

Quantity = Literal["temperature", "flux", "humidity", "moisture_flux"]
ABSOLUTE_ZERO = -273.15  # °C
#: Default plausible range of a measured temperature (°C): a laboratory thermal test, from liquid-nitrogen
#: cooling to a furnace; a wider one is stated with ``--plausible``.
PLAUSIBLE = (-200.0, 1500.0)
SENTINELS = (9999.0, 99999.0, 999999.0, 6999.0)  # with either sign: logger codes for "no reading"
OVERFLOW = 1e30  # magnitudes from here on are overflow codes (9.9e37), never readings
SPIKE_RATIO = 20.0
#: Unstated data whose mean lies this much closer to the scene's start in kelvin than in °C are called kelvin.
KELVIN_MARGIN = 100.0
FAHRENHEIT_MARGIN = 10.0  #: °C: how much closer to the Fahrenheit reading than to the initial temperature


def _where(path: Path, line: int, column: str) -> str:
    return f"{path} line {line}, column {column!r}"


def check_values(path: Path, values: FloatArray, lines: Sequence[int], column: str, quantity: Quantity, *,
                 kelvin: bool = False, plausible: tuple[float, float] = PLAUSIBLE) -> None:
    """Refuse sentinels, non-finite values and (for temperatures, in K when ``kelvin``) values below absolute
    zero, outside ``plausible`` (°C), or a single outlier; InputError naming ``path``, the line and ``column``."""
    for v, line in zip(values, lines, strict=True):
        where = _where(path, line, column)
        if not math.isfinite(v):
            raise InputError(f"{where}: {v!r} is not finite (a logger's 'no reading'?); remove the row or leave the "
                             "cell empty (rows with an empty cell are dropped)")
        if abs(v) >= OVERFLOW or abs(v) in SENTINELS:
            raise InputError(f"{where}: {v:g} is a logger sentinel (overflow or 'no reading' code: ±9999, 9.9e37, "
                             "...), not a reading; remove the row or leave the cell empty (rows with an empty cell "
                             "are dropped)")
    if quantity != "temperature":
        return
    celsius = values - 273.15 if kelvin else values
    unit = "K" if kelvin else "°C"
    low, high = plausible
    for v, c, line in zip(values, celsius, lines, strict=True):
        where = _where(path, line, column)
        if c < ABSOLUTE_ZERO:
            raise InputError(f"{where}: {v:g} {unit} is below absolute zero (−273.15 °C, 0 K)")
        if not low <= c <= high:
            raise InputError(f"{where}: {v:g} {unit} is outside the plausible range [{low:g}, {high:g}] °C of a "
                             "measured temperature; a reading error? (state another range with --plausible LOW:HIGH)")
    spike = single_outlier(np.asarray(celsius, dtype=float))
    if spike is not None:
        i = spike
        raise InputError(f"{_where(path, lines[i], column)}: {values[i]:g} {unit} is a single outlier (its neighbours "
                         f"read {values[i - 1]:g} and {values[i + 1]:g}): heat diffuses, a temperature cannot jump for "
                         "one sample; check the logger, then remove the row or leave the cell empty")


def single_outlier(y: FloatArray) -> int | None:
    """Index of the most extreme one-sample spike of ``y`` (module docstring), or None.

    >>> single_outlier(np.array([20.0, 20.1, 20.2, 35.0, 20.4, 20.5]))
    3
    >>> single_outlier(np.array([20.0, 20.1, 20.2, 30.0, 30.1, 30.2])) is None   # a step, not a spike
    True
    """
    if y.size < 3:
        return None
    up, down = y[1:-1] - y[:-2], y[1:-1] - y[2:]
    same = np.sign(up) == np.sign(down)
    jump = np.minimum(np.abs(up), np.abs(down))
    d = np.diff(y)
    steps = np.abs(d[d != 0])
    resolution = float(steps.min()) if steps.size else 0.0  # a logger's quantum: one step is never a spike
    noise = max(1.4826 * float(np.median(np.abs(d - np.median(d)))), resolution)
    floor = np.maximum(np.abs(y[2:] - y[:-2]), noise)
    ratio = np.where(same & (jump > 0), jump / np.maximum(floor, np.finfo(float).tiny), 0.0)
    worst = int(np.argmax(ratio))
    return worst + 1 if ratio[worst] > SPIKE_RATIO else None


def kelvin_suspect(values: FloatArray, initial: float) -> bool:
    """Whether temperatures read as °C look like kelvin for a scene starting at ``initial`` °C: their first
    values lie near ``initial + 273.15`` and far from ``initial`` (by :data:`KELVIN_MARGIN` at least)."""
    first = float(np.median(np.asarray(values, dtype=float)[:5]))
    return abs(first - initial - 273.15) + KELVIN_MARGIN < abs(first - initial)


def fahrenheit_suspect(values: FloatArray, initial: float) -> bool:
    """Whether temperatures read as °C look like degrees Fahrenheit for a scene starting at ``initial`` °C: their
    first values lie near ``1.8 initial + 32`` and far from ``initial`` (by :data:`FAHRENHEIT_MARGIN` at least).

    >>> fahrenheit_suspect(np.array([68.1, 68.3]), 20.0), fahrenheit_suspect(np.array([20.1, 20.4]), 20.0)
    (True, False)
    """
    first = float(np.median(np.asarray(values, dtype=float)[:5]))
    return abs(first - (1.8 * initial + 32.0)) + FAHRENHEIT_MARGIN < abs(first - initial)

