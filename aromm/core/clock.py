"""A clock offset between the measurements and the model: the model evaluated at t + δ.

Data loggers and heaters are rarely synchronised: the measurement stamped t was taken at model time
``t + δ`` (δ in s, the parameter ``time_offset``).  :class:`TimeShifted` wraps any forward model
(:mod:`aromm.core.forward_model`) so that δ is one more parameter, which an identification can estimate jointly
with the phase properties (``--unknown time_offset=-0.5:0.5``)::

    Ŷ(t_i; β, δ) = Y_model(max(t_i + δ, 0); β).

Before t = 0 nothing has happened yet: the body is at its initial state, so times shifted below zero
are evaluated at zero.  The full model needs its ``[time] end`` to cover ``t_last + δ``; the reduced
model is exact at any time.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.forward_model import ForwardModel, one_set
from aromm.core.observables import Observables
from aromm.core.system import FloatArray

#: The parameter name of the clock offset δ (s): the model is evaluated at t + δ.
TIME_OFFSET = "time_offset"


@dataclass(frozen=True)
class TimeShifted:
    """``model`` evaluated at ``t + time_offset`` (parameter default ``offset``, s); a forward model itself."""

    model: ForwardModel
    offset: float = 0.0

    def __post_init__(self) -> None:
        if TIME_OFFSET in self.model.parameter_names:
            raise InputError(f"the model already has a parameter {TIME_OFFSET!r}")

    @property
    def outputs(self) -> tuple[str, ...]:
        return self.model.outputs

    @property
    def output_error(self) -> float:
        """The wrapped model's own output error (°C), if it states one."""
        return float(getattr(self.model, "output_error", 0.0))

    @property
    def parameter_names(self) -> frozenset[str]:
        return self.model.parameter_names | {TIME_OFFSET}

    @property
    def default_times(self) -> FloatArray:
        return self.model.default_times

    def simulate(self, params: Mapping[str, float] | None = None,
                 times: npt.ArrayLike | None = None) -> Observables:
        return one_set(self, params, self._times(times))

    def simulate_batch(self, params: Mapping[str, npt.ArrayLike],
                       times: npt.ArrayLike | None = None) -> FloatArray:
        """Outputs (m, len(times), n_outputs); parameter sets sharing an offset are evaluated together."""
        t = self._times(times)
        arrays = {k: np.atleast_1d(np.asarray(v, dtype=float)).ravel() for k, v in params.items()}
        sizes = {a.size for a in arrays.values()} - {1}
        if len(sizes) > 1:
            raise InputError(f"parameter arrays must have equal lengths, got {sorted(sizes)}")
        m = sizes.pop() if sizes else 1
        rest = {k: np.broadcast_to(a, (m,)) for k, a in arrays.items()}
        shift = rest.pop(TIME_OFFSET, np.full(m, float(self.offset)))
        if not np.all(np.isfinite(shift)):
            raise InputError(f"{TIME_OFFSET} must be finite (s)")
        out: FloatArray | None = None
        for delta in np.unique(shift):
            rows = np.flatnonzero(shift == delta)
            moved = np.maximum(t + delta, 0.0)
            at, back = np.unique(moved, return_inverse=True)
            sub = {k: a[rows] for k, a in rest.items()}
            y = np.asarray(self.model.simulate_batch(sub, at), dtype=float)[:, back]
            if out is None:
                out = np.empty((m, t.size, y.shape[2]))
            out[rows] = y
        assert out is not None
        return out

    def _times(self, times: npt.ArrayLike | None) -> FloatArray:
        return np.asarray(self.default_times if times is None else times, dtype=float).ravel()
