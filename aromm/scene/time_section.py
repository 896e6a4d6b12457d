"""The ``[time]`` section of a scene: the output grid ``dt, 2 dt, …, end`` (s), given or derived from the material.

``end = "auto"`` and/or ``dt = "auto"`` ask for the grid a first experiment on a new material needs, from two time
scales of the sample [Carslaw1959, ch. 3]: its diffusion time along the axis its faces load, and the time constant of
its exchange with the surroundings (the body as one lumped capacity behind its faces' conductances)::

    t_D = c̄ L² / k,   τ_h = c̄ V / Σ_f h_f A_f,   c̄ = Σ_i φ_i c_i,   k_⊥ ≤ k_eff ≤ k_∥,
    k_∥ = Σ_i φ_i k_i,   1/k_⊥ = Σ_i φ_i / k_i,

with φ_i the volume fractions, ``L`` the sample's length along the axis of its faces with a condition (the longest
such axis; every axis when no face has one), ``V`` its volume and ``A_f`` the area of an exchange face (``τ_h = 0``
when a face has a fixed temperature or none exchanges), ``c̄`` exact (capacities add by volume) and ``k_⊥``, ``k_∥``
the Wiener bounds of the effective conductivity of any microstructure of these fractions [Wiener1912].  The slowest
mode of the body decays with a time constant below ``t_D + τ_h`` (the internal and the exchange resistances in
series; ``4 t_D/π²`` for a slab with one fixed face, ``τ_h`` when the Biot number is small).  So, whatever the
microstructure,

* ``end = AUTO_CONSTANTS · (t_D(k_⊥) + τ_h)``: three time constants at least, 95 % of the way to the steady or the
  linearly rising state: the response holds the transient (where the capacities show) and the approach to it (the
  conductivities);
* ``dt = min(end / AUTO_STEPS, t_D(k_∥) / AUTO_PER_DIFFUSION)``: ten outputs at least within the diffusion time, which
  carries the conductivities' signature on the loaded face, and a hundred in all.

The spread of the two bounds (a laminate across the axis reaches ``k_⊥``, one along it ``k_∥``) is the price of
knowing nothing of the microstructure: ``aromm homogenize`` gives k_eff, and with it a tighter grid by hand (a
transient scene has no insulating phase: every phase conducts, so ``k_⊥ > 0``).  ``dt`` is rounded to two
significant digits and ``end`` to a whole number of steps; the rule and its numbers are logged (the command line
always shows them).

>>> from aromm.core.vocabulary import FaceSpec, PhaseSpec, loaded_axis
>>> phases = (PhaseSpec("a", 0, 1.0, 1e6), PhaseSpec("b", 1, 1.0, 1e6))
>>> grid, why = auto_grid(AutoTime(), {"a": 0.5, "b": 0.5}, phases, (FaceSpec("z0", flux=1.0),), (0.01, 0.01, 0.01))
>>> grid.end, grid.dt
(300.0, 3.0)
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from aromm.core.errors import InputError
from aromm.core.resources import MAX_TIME_STEPS
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec, loaded_axis
from aromm.scene.toml import TableReader

log = logging.getLogger(__name__)

AUTO = "auto"
#: ``end`` of an automatic grid in time constants ``t_D + τ_h`` (module docstring).
AUTO_CONSTANTS = 3.0
#: Output times of an automatic grid, at least (``dt ≤ end / AUTO_STEPS``).
AUTO_STEPS = 100
#: Output times within one diffusion time, at least (``dt ≤ t_D / AUTO_PER_DIFFUSION``).
AUTO_PER_DIFFUSION = 10


@dataclass(frozen=True)
class AutoTime:
    """A ``[time]`` section with ``"auto"`` in it: the given ``end`` or ``dt`` (s), None where it is automatic."""

    end: float | None = None
    dt: float | None = None


def parse_time(r: TableReader, data: Mapping[str, Any]) -> TimeGrid | AutoTime | None:
    """The ``[time]`` section: None (steady scene), a grid, or what :func:`auto_grid` completes once the material
    is known."""
    if "time" not in data:
        return None
    t = r.table(data, "time", ("end", "dt"))
    if "end" not in t:
        raise r.fail("time", 'needs end (s, or "auto": one diffusion time of the sample) and dt (s, or "auto")')
    end = _seconds(r, t["end"], "time.end")
    if "dt" not in t:
        if end is not None:
            raise r.fail("time", 'needs dt (s, or "auto": end / 100)')
        dt = None
    else:
        dt = _seconds(r, t["dt"], "time.dt")
    if end is None or dt is None:
        return AutoTime(end, dt)
    return checked_grid(end, dt, r.path)


def _seconds(r: TableReader, value: Any, key: str) -> float | None:
    if isinstance(value, str) and value.strip().lower() == AUTO:
        return None
    if isinstance(value, str):
        raise r.fail(key, f'must be a number of seconds or "auto", got {value!r}')
    return r.number(value, key, positive=True)


def checked_grid(end: float, dt: float, path: Any = None) -> TimeGrid:
    """``TimeGrid(end, dt)``, refused (naming ``[time]`` in the scene ``path``) when ``end < dt`` or when it holds more
    than :data:`~aromm.core.resources.MAX_TIME_STEPS` steps."""
    r = TableReader(path)
    if end < dt:
        raise r.fail("time.end", f"end ({end:g} s) must be at least dt ({dt:g} s)")
    if end / dt > MAX_TIME_STEPS:
        raise r.fail("time", f"end / dt = {end:g} s / {dt:g} s = {end / dt:.3g} time steps, more than the "
                             f"{MAX_TIME_STEPS:.0e} allowed; raise dt or lower end")
    return TimeGrid(end, dt)


def time_scales(fractions: Mapping[str, float], phases: Sequence[PhaseSpec], boundary: Sequence[FaceSpec],
                size: tuple[float, float, float]) -> tuple[tuple[float, float], float, str]:
    """``((t_D(k_∥), t_D(k_⊥)), τ_h)`` (s) of the module docstring, and the sentence that says how they were obtained.

    >>> (fast, slow), tau, why = time_scales({"a": 1.0}, (PhaseSpec("a", 0, 2.0, 4e6),), (FaceSpec("y1", h=10.0),),
    ...                                      (0.01, 0.02, 0.01))
    >>> fast, slow, tau  # along y: 4e6 × 0.02² / 2, and 4e6 × 0.01 × 0.02 × 0.01 / (10 × 0.01 × 0.01)
    (800.0, 800.0, 8000.0)
    """
    axis = loaded_axis(boundary, size)
    length = size[axis]
    present = [ph for ph in phases if fractions.get(ph.name, 0.0) > 0.0]
    bounds = {ph.name: _along(ph, axis) for ph in present}  # (lowest, highest) along the axis
    c_bar = sum(fractions[ph.name] * float(ph.c or 0.0) for ph in present)
    parallel = sum(fractions[ph.name] * bounds[ph.name][1] for ph in present)
    if c_bar <= 0 or parallel <= 0:
        raise InputError('[time] "auto" needs a phase with k > 0 and c > 0')
    connected = all(bounds[ph.name][0] > 0 for ph in present)
    series = 1.0 / sum(fractions[ph.name] / bounds[ph.name][0] for ph in present) if connected else 0.0
    scale = c_bar * length**2
    times = (scale / parallel, scale / series if series > 0 else math.inf)
    why = (f"t_D = c̄ L²/k = {c_bar:.3g} J/(m³ K) × ({length:.3g} m)² / k = {times[0]:.3g}–{times[1]:.3g} s for k "
           f"between the Wiener bounds {parallel:.3g} and {series:.3g} W/(m K) (L along {'xyz'[axis]})")
    volume = size[0] * size[1] * size[2]
    conductance = sum(float(f.h or 0.0) * volume / size[f.axis] for f in boundary)
    if conductance > 0 and all(f.T is None for f in boundary):
        tau = c_bar * volume / conductance
        return times, tau, why + f", τ_h = c̄ V / Σ h A = {tau:.3g} s"
    return times, 0.0, why


def _along(phase: PhaseSpec, axis: int) -> tuple[float, float]:
    """Bounds (W/(m K)) of a phase's conductivity along an axis: its value, or an anisotropic tensor's smallest and
    largest principal values (the component along any axis lies between them)."""
    if phase.tensor is not None:
        return float(min(phase.tensor.values)), float(max(phase.tensor.values))
    k = float(phase.k[axis]) if isinstance(phase.k, tuple) else float(phase.k)
    return k, k


def auto_grid(request: AutoTime, fractions: Mapping[str, float], phases: Sequence[PhaseSpec],
              boundary: Sequence[FaceSpec], size: tuple[float, float, float], *,
              path: Any = None) -> tuple[TimeGrid, str]:
    """The grid a request with ``"auto"`` asks for (module docstring) and the sentence that explains it (also logged
    at INFO)."""
    (fast, slow), tau, reason = time_scales(fractions, phases, boundary, size)
    end = request.end if request.end is not None else AUTO_CONSTANTS * (slow + tau)
    dt = request.dt if request.dt is not None else _two_digits(min(end / AUTO_STEPS, fast / AUTO_PER_DIFFUSION))
    if request.end is None:
        end = max(1, round(end / dt)) * dt
    elif request.dt is None:
        dt = end / math.ceil(end / dt - 1e-9)  # a whole number of steps up to the given end
    rule = (f"end = {AUTO_CONSTANTS:g} (t_D + τ_h) at the lower bound" if request.end is None else "end given") + (
        f", dt = min(end/{AUTO_STEPS}, t_D/{AUTO_PER_DIFFUSION}) at the upper" if request.dt is None else
        ", dt given")
    why = f"end = {end:.6g} s, dt = {dt:.6g} s ({round(end / dt)} outputs): {rule}; {reason}"
    grid = checked_grid(end, dt, path)
    log.info("[time] auto: %s", why)
    return grid, why


def _two_digits(value: float) -> float:
    """``value`` rounded to two significant digits."""
    return float(f"{value:.2g}")
