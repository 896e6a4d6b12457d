"""The forward-model protocol shared by the full model, the reduced model and the inverse loop.

A forward model maps parameter values to face-mean temperatures at given times.  The
inverse loop only needs :meth:`ForwardModel.simulate_batch`, which evaluates a whole
swarm of parameter sets in one call [Chavez2020, § 4: PSO evaluates many candidates].
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

import numpy.typing as npt

from aromm.core.observables import Observables
from aromm.core.system import FloatArray


@runtime_checkable
class ForwardModel(Protocol):
    """What ``aromm.simulate``'s FullModel and the AROMM ReducedModel both provide."""

    @property
    def outputs(self) -> tuple[str, ...]:
        """Names of the observed outputs (faces), in the order of the last axis of simulate_batch."""
        ...

    @property
    def parameter_names(self) -> frozenset[str]:
        """Parameters the model accepts (e.g. ``"fibre.k"``)."""
        ...

    @property
    def default_times(self) -> FloatArray:
        """Output times (s) of the scene's time grid."""
        ...

    def simulate(self, params: Mapping[str, float] | None = None,
                 times: npt.ArrayLike | None = None) -> Observables:
        """One parameter set (overrides of the scene's values) -> Observables at ``times``."""
        ...

    def simulate_batch(self, params: Mapping[str, npt.ArrayLike],
                       times: npt.ArrayLike | None = None) -> FloatArray:
        """Arrays of equal length m per parameter -> outputs of shape (m, len(times), len(outputs))."""
        ...


def one_set(model: ForwardModel, params: Mapping[str, float] | None, t: FloatArray) -> Observables:
    """:meth:`ForwardModel.simulate` through ``simulate_batch``: one parameter set, outputs at times ``t``."""
    y = model.simulate_batch({k: [v] for k, v in (params or {}).items()}, t)[0]
    return Observables(t=t, mean_T={name: y[:, i] for i, name in enumerate(model.outputs)})
