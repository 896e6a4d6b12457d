"""What every command checks before its expensive work (issue 10): inputs listed, unknowns and measurements
against the scene as read from its file (no assembly), the cache folder.

A bad ``--unknown`` or measurement CSV is refused in the time it takes to read the scene file and its image,
not after a reduced-model build (tests/test_faults.py times it on the shipped wood scene).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import click

from aromm.core.cache import ENV_VAR, NpzCache
from aromm.core.clock import TIME_OFFSET
from aromm.core.errors import InputError
from aromm.core.files import Input, check_folder
from aromm.core.vocabulary import is_positive
from aromm.scene.file import Scene, scene_files
from inverse.measurements import Measurements, load_measurements

Bounds = dict[str, tuple[float, float]]


def scene_inputs(path: Path, role: str = "the scene file") -> list[Input]:
    """The scene file and every file it names, with their roles in messages (run after the scene loaded)."""
    first, *named = scene_files(path)
    return [(first, role), *((f, f"a file named by the scene {path}") for f in named)]


def parse_unknown(text: str) -> tuple[str, tuple[float, float]]:
    """``NAME=LOW:HIGH`` (SI units), e.g. ``fibre.k=0.05:1`` or ``fibre.c=1e5:1e7``."""
    name, eq, bounds = text.partition("=")
    low, colon, high = bounds.partition(":")
    try:
        if not (eq and colon and name.strip()):
            raise ValueError
        lo, hi = float(low), float(high)
    except ValueError:
        raise click.BadParameter(f"{text!r}: expected NAME=LOW:HIGH, e.g. fibre.k=0.05:1",
                                 param_hint="--unknown") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise click.BadParameter(f"{text!r}: bounds must be finite with LOW < HIGH", param_hint="--unknown")
    return name.strip(), (lo, hi)


def unknowns(texts: Sequence[str], scene: Scene) -> Bounds:
    """The ``--unknown`` options checked against ``scene``: known names (its parameters and ``time_offset``),
    each given once, positive intervals for conductivities, capacities and exchange coefficients."""
    known = sorted({*scene.parameters, TIME_OFFSET})
    out: Bounds = {}
    for text in texts:
        name, (lo, hi) = parse_unknown(text)
        if name in out:
            raise click.BadParameter(f"{name} is given twice; give each unknown once", param_hint="--unknown")
        if name not in known:
            raise click.BadParameter(f"{name!r} is not a parameter of {scene.path}; allowed: {', '.join(known)}",
                                     param_hint="--unknown")
        if is_positive(name) and lo <= 0:
            raise click.BadParameter(f"{text!r}: {name} is positive by nature; give 0 < LOW < HIGH",
                                     param_hint="--unknown")
        out[name] = (lo, hi)
    return out


def measurements(path: Path, scene: Scene, kind: str, bounds: Bounds) -> Measurements:
    """The measurement CSV, its columns among the scene's outputs; for the full model, its last time (plus the
    largest clock offset searched) within the scene's ``[time] end``."""
    data = load_measurements(path, scene.outputs)
    if kind == "full" and scene.time is not None:
        reach = float(data.t[-1]) + max(0.0, bounds.get(TIME_OFFSET, (0.0, 0.0))[1])
        if reach > scene.time.end * (1 + 1e-9):
            raise InputError(f"{path}: the last time {reach:g} s (measurements, plus the largest time_offset) is "
                             f"past the end of {scene.path} ([time] end = {scene.time.end:g} s); "
                             "raise end, or use --model reduced (exact at any time)")
    return data


def cache_folder(directory: Path | None, option: str = "--cache-dir") -> Path:
    """The cache folder (``directory``, else ``$AROMM_CACHE_DIR`` or the user's cache), writable or creatable."""
    folder = NpzCache(directory).directory
    return check_folder(folder, "cache", option if directory is not None else f"cache folder (${ENV_VAR})")
