"""Resource guards: refuse, before any work, a computation whose kept arrays cannot fit in memory.

:func:`available_memory` is what this process may still allocate (bytes): ``AROMM_MEMORY_LIMIT`` when
set (``"4G"``, ``"512M"``, ``"2.5e9"``), else the least of the kernel's ``MemAvailable`` and the
control group's limit minus its usage (cgroup v2 or v1); ``None`` when none is known (then no
guard).  :func:`require` raises :class:`~aromm.core.errors.InputError` (exit 2 on the command line)
with the estimate, what it is made of and the knob that lowers it.  Estimates count only the arrays
a computation keeps (outputs per time step, fields); factorisations and solver work space come on
top and are not estimated.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from aromm.core.errors import InputError

MAX_TIME_STEPS = 10_000_000  # a [time] grid with more steps is refused when the scene is loaded
FLOAT = 8  # bytes per float64
_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}
_CGROUP_LIMITS = (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                  ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes"))


def gigabytes(nbytes: float) -> str:
    return f"{nbytes / 1e9:.3g} GB"


def _parse_limit(text: str) -> int:
    match = re.fullmatch(r"\s*([0-9.eE+]+)\s*([KMGT]?)i?B?\s*", text, flags=re.IGNORECASE)
    try:
        if match is None:
            raise ValueError
        value = float(match.group(1)) * _UNITS[match.group(2).upper()]
    except ValueError:
        raise InputError(f"AROMM_MEMORY_LIMIT={text!r}: expected bytes with an optional unit K, M, G or T "
                         "(e.g. 4G, 512M, 2.5e9)") from None
    if not value > 0:
        raise InputError(f"AROMM_MEMORY_LIMIT={text!r}: must be positive")
    return int(value)


def _read_int(path: str) -> int | None:
    try:
        text = Path(path).read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError):
        return None
    return int(text) if text.isdigit() else None


def _meminfo_available() -> int | None:
    try:
        for line in Path("/proc/meminfo").read_text(encoding="ascii").splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, UnicodeDecodeError, ValueError, IndexError):
        return None
    return None


def available_memory() -> tuple[int | None, str]:
    """Bytes this process may still allocate, and where the figure comes from (``None``: unknown)."""
    limit = os.environ.get("AROMM_MEMORY_LIMIT")
    if limit:
        return _parse_limit(limit), "AROMM_MEMORY_LIMIT"
    found: list[tuple[int, str]] = []
    avail = _meminfo_available()
    if avail is not None:
        found.append((avail, "MemAvailable"))
    for cap_path, used_path in _CGROUP_LIMITS:
        cap, used = _read_int(cap_path), _read_int(used_path)
        if cap is not None and used is not None:
            found.append((max(cap - used, 0), "cgroup limit"))
            break
    if not found:
        return None, "unknown"
    return min(found)


def require(nbytes: float, what: str, made_of: str, knob: str) -> None:
    """Refuse ``what`` when the ``nbytes`` it keeps exceed the available memory (InputError with the numbers)."""
    avail, source = available_memory()
    if avail is not None and nbytes > avail:
        raise InputError(f"{what} would keep {gigabytes(nbytes)} ({made_of}), more than the {gigabytes(avail)} "
                         f"available ({source}); {knob}, or set AROMM_MEMORY_LIMIT if the figure is wrong")
