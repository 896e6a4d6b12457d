"""Typed access to the tables of a TOML file (scene files), with messages naming the file and the dotted key."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from aromm.core.errors import InputError

#: Plausible ranges of the scene's physical numbers (SI): a value outside is a unit slip or a typo, refused with the
#: range and a familiar value.  (kind: (lowest, highest, unit, examples))
PLAUSIBLE = {
    "voxel_size": (1e-10, 10.0, "m", "1e-6 m for a micro-CT voxel"),
    "k": (1e-5, 1e4, "W/(m K)", "0.026 for air, 400 for copper"),
    "c": (10.0, 1e8, "J/(m³ K)", "the volumetric ρ c_p: 1.2e3 for air, 4.2e6 for water"),
    "h": (1e-3, 1e7, "W/(m² K)", "5–25 for free convection in air"),
}


def where(path: Path | None) -> str:
    """Prefix naming a file in messages: ``"<file>: "``, or ``"scene: "`` for a scene built in Python."""
    return f"{path}: " if path is not None else "scene: "


class TableReader:
    """Typed access to a TOML table with messages naming the file and the dotted key."""

    def __init__(self, path: Path | None) -> None:
        self.path = path

    def fail(self, key: str, message: str) -> InputError:
        return InputError(f"{where(self.path)}{key}: {message}")

    def table(self, data: Mapping[str, Any], key: str, allowed: tuple[str, ...] | None,
              name: str | None = None) -> dict[str, Any]:
        """The sub-table ``data[name]`` (default: last part of the dotted ``key``), keys checked."""
        value = data.get(name if name is not None else key.rsplit(".", 1)[-1], {})
        if not isinstance(value, dict):
            raise self.fail(key, f"must be a table, got {type(value).__name__}")
        if allowed is not None:
            unknown = sorted(set(value) - set(allowed))
            if unknown:
                raise self.fail(key, f"unknown key(s) {unknown}; allowed: {', '.join(allowed)}")
        return value

    def number(self, value: Any, key: str, positive: bool = False, plausible: str | None = None) -> float:
        """A finite number (``positive``: > 0); ``plausible``: a kind of :data:`PLAUSIBLE`, whose range it must lie in
        (0 and negative values are left to the caller: an insulating phase, a refusal naming the sign)."""
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise self.fail(key, f"must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.fail(key, f"must be > 0, got {value!r}")
        if plausible is not None and value > 0:
            low, high, unit, familiar = PLAUSIBLE[plausible]
            if not low <= value <= high:
                raise self.fail(key, f"{value:g} {unit} is outside the plausible range [{low:g}, {high:g}] {unit} "
                                     f"({familiar}): a unit slip?")
        return float(value)


