"""Shifted-solve correction vectors: Laplace-domain samples of the load response (rational Krylov moments).

The static and first-moment correction vectors of aromm.reduction.modal_bases match the response at s = 0 (late times).
The early response — a boundary layer growing under the heated face over the first output times — lives at
Laplace frequencies s ≈ 1/t.  A correction sample with a shift s adds ``(K(p) + s C(p))⁻¹ U_j`` and
``(K(p) + s C(p))⁻¹ C_i (K(p) + s C(p))⁻¹ U_j`` for every load U_j and capacity term C_i: the transfer
function and its derivative interpolated at s (moment matching at a non-zero point, as rational Krylov
and IRKA do [Antoulas2005, ch. 11]), for shifts spread between 1/t_end and 1/t_first.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import TimeGrid

#: Key of a correction sample holding its Laplace shift s (1/s); not a parameter of the system.
SHIFT = "correction.shift"


def default_shifts(grid: TimeGrid | None, count: int = 4) -> list[float]:
    """``count`` shifts (1/s) log-spaced from 1/t_end to 1/t_first of the output grid."""
    if grid is None:
        raise InputError("shifted corrections need a time grid ([time] section)")
    if count < 1:
        raise InputError(f"the number of shifts must be >= 1, got {count}")
    return [float(s) for s in np.geomspace(1.0 / grid.end, 1.0 / grid.dt, count)]


def shifted_samples(samples: Sequence[Mapping[str, float]], shifts: Sequence[float]) -> list[dict[str, float]]:
    """Every sample (parameter values) once per shift, as correction samples for ``aromm.reduce``."""
    bad = [s for s in shifts if not (np.isfinite(s) and s > 0)]
    if bad:
        raise InputError(f"shifts must be finite and positive (1/s), got {bad}")
    return [{**dict(sample), SHIFT: float(s)} for sample in samples for s in shifts]
