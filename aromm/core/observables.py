"""One time-series table for what a model computes and what a laboratory measures, and its CSV file.

An :class:`Observables` holds times ``t`` (s) and one series per output (a face-mean temperature in °C,
named by its face, e.g. ``"z0"``, or a sensor's reading named by the sensor, e.g. ``"tc1"``, ``"cam_0_3"``:
aromm.scene.sensors).  Simulations return one; measurements are one (``inverse.Measurements``
is this class); the identification compares two of them [Chavez2020, eq. 4, 12].

The file format is a CSV with a header ``t,<output>,...`` and one row per time, times strictly
increasing, values in full float precision.  :func:`read_csv` refuses every problem with an
:class:`~aromm.core.errors.InputError` naming the file, line and column; :func:`write_csv` writes atomically.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from aromm.core.errors import InputError
from aromm.core.files import OutputKind, atomic_write
from aromm.core.system import FloatArray

HEADER_TIME = "t"
#: The name of an output's relative-humidity twin (aromm.physics.hygrothermal): ``phi:<output>``, in 1, not °C.
PHI_PREFIX = "phi:"


def output_kind(name: str) -> str:
    """``"phi"`` for a relative humidity (an output named ``phi:<face>``, in 1), else ``"T"`` (°C).

    >>> output_kind("z1"), output_kind("phi:z1")
    ('T', 'phi')
    """
    return "phi" if name.startswith(PHI_PREFIX) else "T"


@dataclass(frozen=True)
class Observables:
    """Times ``t`` (s, strictly increasing) and one series (°C) per output, in ``mean_T`` (output → values).

    A steady simulation has ``t == [0.]`` and ``steady`` set; ``fields`` holds full temperature fields
    (rows at ``t``) only when asked for; ``source`` names where the table came from (a file) in messages.
    """

    t: FloatArray
    mean_T: Mapping[str, FloatArray]
    steady: bool = False
    fields: FloatArray | None = None
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        where = f"{self.source}: " if self.source else ""
        if t.ndim != 1 or t.size == 0:
            raise InputError(f"{where}times must be a non-empty 1-D array")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError(f"{where}times must be finite and strictly increasing")
        for name, v in self.mean_T.items():
            arr = np.asarray(v, dtype=float)
            if arr.shape != t.shape:
                raise InputError(f"{where}output {name!r} has {arr.size} values for {t.size} times")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{where}output {name!r} has non-finite values")

    @property
    def outputs(self) -> tuple[str, ...]:
        """Output names, in column order."""
        return tuple(self.mean_T)

    @property
    def faces(self) -> tuple[str, ...]:
        """The output names (measurements speak of faces)."""
        return self.outputs

    @property
    def values(self) -> Mapping[str, FloatArray]:
        """The series by output name (same as ``mean_T``)."""
        return self.mean_T

    def as_array(self) -> FloatArray:
        """Series stacked as (len(t), n_outputs) in the order of :attr:`outputs`."""
        return np.column_stack([np.asarray(v, dtype=float) for v in self.mean_T.values()])

    def to_json(self) -> dict[str, object]:
        return {"t": np.asarray(self.t).tolist(), "mean_T": {k: np.asarray(v).tolist() for k, v in self.mean_T.items()}}

    def with_noise(self, sigma: float, rng: np.random.Generator, humidity: float = 0.0) -> Observables:
        """Independent Gaussian noise of standard deviation ``sigma`` (°C) added to every temperature, ``humidity``
        to every relative humidity (``phi:`` outputs, :func:`output_kind`)."""
        for value, what in ((sigma, "a temperature (°C)"), (humidity, "a relative humidity")):
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"noise sigma must be a finite non-negative {what}, got {value!r}")
        noisy = {f: np.asarray(v, dtype=float) + (humidity if output_kind(f) == "phi" else sigma)
                 * rng.standard_normal(len(self.t)) for f, v in self.mean_T.items()}
        return Observables(np.asarray(self.t, dtype=float), noisy, source=self.source)

    def check_outputs(self, allowed: Iterable[str]) -> None:
        """Refuse outputs the model does not compute (InputError naming them and the allowed ones)."""
        allowed = tuple(allowed)
        unknown = [f for f in self.outputs if f not in allowed]
        if unknown:
            where = f"{self.source}: " if self.source else ""
            raise InputError(f"{where}output(s) {', '.join(unknown)} are not outputs of the model; "
                             f"allowed: {', '.join(allowed) or '(none)'}")


def read_csv(path: str | os.PathLike[str], outputs: Iterable[str] | None = None) -> Observables:
    """Read a ``t,<output>,...`` CSV; ``outputs`` (e.g. ``model.outputs``) lists the allowed column names.

    >>> import tempfile, pathlib
    >>> file = pathlib.Path(tempfile.mkdtemp()) / "y.csv"
    >>> _ = file.write_text("t,z0\\n0.5,1.25\\n1.0,2.5\\n")
    >>> read_csv(file, ["z0", "z1"]).mean_T["z0"].tolist()
    [1.25, 2.5]
    """
    p = Path(path)
    allowed = tuple(outputs) if outputs is not None else None
    try:
        text = p.read_text(encoding="utf-8-sig")  # tolerates the byte-order mark of spreadsheet exports
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{p}: cannot read the time-series file ({err})") from None
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(text.splitlines())) if any(c.strip() for c in r)]
    if not rows:
        raise InputError(f"{p}: empty file; expected a header 't,<face>,...' and one row per time")
    header_line, header = rows[0]
    header = [h.strip() for h in header]
    if header[0] != HEADER_TIME or len(header) < 2:
        raise InputError(f"{p} line {header_line}: the header must be 't,<face>,...' "
                         f"(time in s, then one column per face), got {','.join(header)!r}")
    names = header[1:]
    for col, name in enumerate(names, start=2):
        if not name:
            raise InputError(f"{p} line {header_line}, column {col}: empty face name")
        if names.count(name) > 1:
            raise InputError(f"{p} line {header_line}: face {name!r} appears twice")
        if allowed is not None and name not in allowed:
            raise InputError(f"{p} line {header_line}, column {col}: {name!r} is not an output of the "
                             f"model (a face or a sensor); allowed: {', '.join(allowed) or '(none)'}")
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
    return Observables(data[:, 0].copy(), values, source=str(p))


def written_by_write_csv(path: Path) -> bool:
    """Whether ``path`` reads exactly as :func:`write_csv` writes: a header ``t,<name>,...``, then rows of as
    many fields, each the shortest ``repr`` of a float (``1.0``, ``0.8915329250625168``), newline-terminated.

    A spreadsheet export or a hand-typed file (``0,20.5``, ``1.50``, ``1e3``) does not; a file another program
    wrote with the same repr convention would.

    >>> import tempfile, pathlib
    >>> file = pathlib.Path(tempfile.mkdtemp()) / "y.csv"
    >>> _ = file.write_text("t,z0\\n0.5,1.25\\n"); written_by_write_csv(file)
    True
    >>> _ = file.write_text("t,z0\\n0,1.25\\n"); written_by_write_csv(file)
    False
    """
    try:
        lines = path.read_text(encoding="utf-8").split("\n")
    except (OSError, UnicodeDecodeError):
        return False
    header = lines[0].split(",")
    if header[0] != HEADER_TIME or len(header) < 2 or len(lines) < 3 or lines[-1] != "":
        return False
    for line in lines[1:-1]:
        cells = line.split(",")
        if len(cells) != len(header):
            return False
        for cell in cells:
            try:
                if repr(float(cell)) != cell:
                    return False
            except ValueError:
                return False
    return True


#: A time-series CSV (observables, measurements) as :func:`write_csv` writes it.
TIME_SERIES = OutputKind("time-series CSV (t,<face>,...)", written_by_write_csv)


def write_csv(table: Observables, path: str | os.PathLike[str], what: str = "time-series file") -> None:
    """Write the ``t,<output>,...`` CSV (full float precision), atomically (:func:`aromm.core.files.atomic_write`)."""
    arr = np.column_stack([np.asarray(table.t, dtype=float), table.as_array()])
    with atomic_write(path, what) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow([HEADER_TIME, *table.outputs])
        w.writerows([[repr(float(v)) for v in row] for row in arr])

