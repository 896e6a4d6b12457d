"""Histories of boundary values in a scene: a CSV file ``t,<value>`` named where a number may stand.

A face value of a scene (a fixed temperature, an exterior temperature, a heat flux; with ``[moisture]`` a fixed or
exterior relative humidity and a moisture flux) is a number, or the name of a CSV file relative to the scene, a
laboratory export read by :func:`aromm.core.labcsv.read_lab_csv` (its units row or header units checked against
the quantity) as a piecewise-linear history held at its last value (:class:`~aromm.core.profiles.Profile`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aromm.core.labchecks import Quantity
from aromm.core.labcsv import read_lab_csv
from aromm.core.profiles import Profile
from aromm.scene.toml import TableReader


def history(r: TableReader, value: str, key: str, quantity: Quantity) -> Profile:
    """The history named by ``value`` at the scene key ``key``; InputError naming the key when the file is missing
    or holds more than one value column."""
    file = Path(value)
    if not file.is_absolute() and r.path is not None:
        file = r.path.parent / file
    if not file.is_file():
        raise r.fail(key, f"history file not found: {file} (a number, or a CSV file t,<value> relative to the scene)")
    table = read_lab_csv(file, quantity=quantity, what=f"history file ({key})").table
    if len(table.outputs) != 1:
        raise r.fail(key, f"{file}: a history has two columns t,<value>, got {', '.join(('t', *table.outputs))}")
    values = np.asarray(next(iter(table.mean_T.values())), dtype=float)
    return Profile(tuple(np.asarray(table.t, dtype=float).tolist()), tuple(values.tolist()), source=str(file))
