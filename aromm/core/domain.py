"""Where a reduced model is valid: its training box and its pinned values.

A Krylov model (``aromm.reduction.krylov``) is trained over a box of parameters, (name, lower, upper) each, with
every other parameter pinned at the scene's value (``ReducedModel.box`` and its parameters;
:meth:`aromm.reduction.rom.ReducedModel.check_domain` applies this module to a model).  Inside the box its greedy
and compression bound the error; outside it, or at another value of a pinned parameter, the model extrapolates, and
nothing bounds its error (a model over fibre.k ∈ [0.01, 100] evaluated at 0.001 was off by 1.5e-2 °C).
:func:`outside` lists what a use leaves the domain by; :func:`warn_outside` says it once, as a
:class:`~aromm.core.errors.ModelWarning` (the command line prints it as one ``aromm: warning:`` line).  A model
without a box (the modal methods, built at the scene's values) records no domain: nothing is said for it.

:func:`training_box` is the box a build should cover for an identification: the scene's ``[reduction] bounds``
joined with the unknowns' ranges (their union, per parameter), so a model is never asked outside its box.
"""

from __future__ import annotations

import warnings
from collections.abc import Collection, Mapping

import numpy as np
import numpy.typing as npt

from aromm.core.errors import ModelWarning

#: Relative slack on the box's ends (the ends come back from text in the cache: 1e-12 covers their rounding).
SLACK = 1e-12

Ranges = Mapping[str, tuple[float, float]]
Box = tuple[tuple[str, float, float], ...]


def outside(box: Box, pinned: Mapping[str, float], values: Mapping[str, npt.ArrayLike],
            scaling: Collection[str] = ()) -> list[str]:
    """Each way ``values`` (name → a value or an array of values) leave the domain of a model trained over ``box``
    with the other parameters at ``pinned``, as text; empty when inside (or when ``box`` is empty: no domain).
    A parameter of ``scaling`` only scales an input (a flux, T_ext, a fixed T: the model is linear in it), so another
    value of it stays in the domain, unless it was pinned at 0 (the input was never excited in the build).

    >>> outside((("fibre.k", 0.1, 1.0),), {"fibre.c": 4e6}, {"fibre.k": 2.0, "fibre.c": 4e6})
    ['fibre.k = 2 outside the training box [0.1, 1]']
    >>> outside((("fibre.k", 0.1, 1.0),), {"fibre.c": 4e6}, {"fibre.c": 1e6})
    ['fibre.c = 1e+06, pinned at 4e+06 in the model']
    """
    if not box:
        return []
    ranges = {name: (lo, hi) for name, lo, hi in box}
    out = []
    for name, value in values.items():
        v = np.atleast_1d(np.asarray(value, dtype=float))
        if name in ranges:
            lo, hi = ranges[name]
            low, high = float(v.min()), float(v.max())
            if low < lo * (1 - SLACK) or high > hi * (1 + SLACK):
                shown = f"{low:g}" if low == high else f"{low:g} … {high:g}"
                out.append(f"{name} = {shown} outside the training box [{lo:g}, {hi:g}]")
        elif name in pinned and not np.allclose(v, pinned[name], rtol=SLACK, atol=0.0) and (
                name not in scaling or pinned[name] == 0.0):
            out.append(f"{name} = {float(v.flat[0]):g}, pinned at {pinned[name]:g} in the model")
    return out


def warn_outside(box: Box, pinned: Mapping[str, float], values: Mapping[str, npt.ArrayLike], use: str,
                 scaling: Collection[str] = ()) -> None:
    """One :class:`~aromm.core.errors.ModelWarning` naming every parameter of ``values`` outside the domain
    (:func:`outside`); ``use`` names what asked (``"simulate"``, ``"identify"``)."""
    found = outside(box, pinned, values, scaling)
    if found:
        warnings.warn(f"{use}: the reduced model extrapolates, its error is not bounded there: {'; '.join(found)} "
                      "(rebuild it over a box that contains them: [reduction] bounds, or --unknown ranges)",
                      ModelWarning, stacklevel=3)


def range_values(ranges: Ranges) -> dict[str, npt.NDArray[np.float64]]:
    """The ends of each range, as the values a search over ``ranges`` reaches."""
    return {name: np.array([float(lo), float(hi)]) for name, (lo, hi) in ranges.items()}


def training_box(scene_bounds: Ranges, unknowns: Ranges) -> dict[str, tuple[float, float]]:
    """The scene's box joined with the unknowns' ranges (per parameter, the smallest interval holding both);
    unknowns whose range is not positive (temperatures, fluxes) are left to the pinned values.

    >>> training_box({"fibre.k": (3.0, 30.0)}, {"fibre.k": (1.0, 60.0), "z1.T_ext": (-5.0, 5.0)})
    {'fibre.k': (1.0, 60.0)}
    """
    box = {name: (float(lo), float(hi)) for name, (lo, hi) in scene_bounds.items()}
    for name, (lo, hi) in unknowns.items():
        if lo <= 0:
            continue
        old = box.get(name, (float(lo), float(hi)))
        box[name] = (min(old[0], float(lo)), max(old[1], float(hi)))
    return box
