"""What an optimiser is: a resumable search for the minimum of a criterion over ``[0, 1]^p``.

:func:`inverse.identify` runs a chain of optimisers (by default a particle swarm, then a least-squares
refinement from its best point).  An optimiser is any object with a ``name`` and a :meth:`Optimiser.run`
method; it reports every step through a callback, with its own state as arrays when it can be resumed
from them (checkpoints), and it draws random numbers only from the ``numpy.random.Generator`` it is given.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from aromm.core.errors import NumericalError
from aromm.core.system import FloatArray

Objective = Callable[[FloatArray], FloatArray]  # (m, p) in [0,1]^p -> (m,) costs
Residuals = Callable[[FloatArray], FloatArray]  # (m, p) in [0,1]^p -> (m, N) residuals
State = Mapping[str, np.ndarray]


@dataclass(frozen=True)
class Problem:
    """A criterion J(u) = ½‖r(u)‖² over ``[0, 1]^dim``, evaluated for m points at once."""

    dim: int
    residuals: Residuals

    def costs(self, u: FloatArray) -> FloatArray:
        """J for each row of ``u``; NumericalError when the criterion is not a finite number."""
        r = np.asarray(self.residuals(np.atleast_2d(u)), dtype=float)
        c = 0.5 * np.einsum("ij,ij->i", r, r)
        if c.shape != (np.atleast_2d(u).shape[0],) or np.any(np.isnan(c)):
            raise NumericalError(f"criterion returned {c.shape} values (NaN present: {bool(np.any(np.isnan(c)))}) "
                                 f"for {np.atleast_2d(u).shape[0]} points")
        return c


@dataclass(frozen=True)
class Step:
    """Reported after each iteration (swarm) or evaluation (refinement): best cost so far, resumable state."""

    step: int
    total: int
    cost: float
    state: State | None = None


@dataclass(frozen=True)
class Outcome:
    """Best point ``u`` (in [0,1]^p), its cost J, evaluations spent and the optimiser's last words."""

    u: FloatArray
    cost: float
    evaluations: int
    message: str = ""
    state: State = field(default_factory=dict)


@runtime_checkable
class Optimiser(Protocol):
    """Minimise ``problem`` from ``start`` (the best point of the previous optimiser, or None).

    ``state`` (arrays an earlier :class:`Step` carried) continues an interrupted run exactly;
    ``callback`` sees every step.
    """

    @property
    def name(self) -> str: ...

    def run(self, problem: Problem, start: FloatArray | None, rng: np.random.Generator, *,
            state: State | None = None, callback: Callable[[Step], None] | None = None) -> Outcome: ...
