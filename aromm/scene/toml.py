"""Typed access to the tables of a TOML file (scene files), with messages naming the file and the dotted key."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from aromm.core.errors import InputError


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

    def number(self, value: Any, key: str, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise self.fail(key, f"must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.fail(key, f"must be > 0, got {value!r}")
        return float(value)


