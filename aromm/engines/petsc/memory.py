"""Peak resident memory of each stage of a build, per rank (Linux), for the records and the memory tests.

:class:`StageMemory` resets the kernel's high-water mark of this process's resident set (``VmHWM``, by
writing ``5`` to ``/proc/self/clear_refs``) when a stage starts and reads it when the stage ends, so each
stage's peak is its own, not that of an earlier stage; its *rise* is that peak less the resident memory when
it started (what the stage itself added, as far as the allocator does not reuse memory freed earlier).
Where ``/proc`` is missing (not Linux) or not writable, the figures are the peak since the process started
(``ru_maxrss``) and ``resettable`` is False.  The largest value over the ranks is kept (bytes).
"""

from __future__ import annotations

import resource
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aromm.engines.petsc import runtime

_STATUS = Path("/proc/self/status")
_CLEAR = Path("/proc/self/clear_refs")


def _status_bytes(key: str) -> int | None:
    """``VmHWM`` or ``VmRSS`` of this process (bytes), None without /proc."""
    try:
        for line in _STATUS.read_text(encoding="ascii").splitlines():
            if line.startswith(f"{key}:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _reset_peak() -> bool:
    try:
        _CLEAR.write_text("5", encoding="ascii")
    except OSError:
        return False
    return True


def resident_bytes() -> int:
    """Resident memory of this process now (bytes; 0 without /proc)."""
    return _status_bytes("VmRSS") or 0


def peak_bytes() -> int:
    """Peak resident memory since the last reset (or since the start), bytes."""
    found = _status_bytes("VmHWM")
    return found if found is not None else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


@dataclass
class StageMemory:
    """Per-stage peak resident memory of this rank, largest over the ranks in :meth:`record`."""

    comm: Any
    peaks: dict[str, int] = field(default_factory=dict)
    rises: dict[str, int] = field(default_factory=dict)
    resettable: bool = True
    _stage: str | None = None
    _resident: int = 0

    def start(self, stage: str) -> None:
        """End the running stage (if any) and start ``stage``."""
        self.stop()
        self.resettable = _reset_peak() and self.resettable
        self._resident = resident_bytes()
        self._stage = stage

    def stop(self) -> None:
        if self._stage is not None:
            self.peaks[self._stage] = peak_bytes()
            self.rises[self._stage] = max(self.peaks[self._stage] - self._resident, 0)
            self._stage = None

    def record(self) -> dict[str, float]:
        """``{"<stage>_peak_bytes": …, "<stage>_rise_bytes": …}``, each the largest over the ranks (collective)."""
        self.stop()
        names = list(self.peaks)
        largest = runtime.allmax_array([self.peaks[k] for k in names] + [self.rises[k] for k in names], self.comm)
        keys = [f"{k}_peak_bytes" for k in names] + [f"{k}_rise_bytes" for k in names]
        return {k: float(v) for k, v in zip(keys, largest, strict=True)}
