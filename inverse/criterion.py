"""The least-squares criterion of [Chavez2020, eq. 12], evaluated for a whole swarm at once.

    J(β) = ½ Σ_i Σ_j w_j² (Y_ij − Ŷ_ij(β))²

over every measurement time i and observed face j (and, for a joint identification, every
scenario); the weights w_j are 1 unless outputs of several kinds are fitted together (temperatures and relative
humidities, :mod:`inverse.kinds`: w = 1/σ of the output's kind).  Ŷ comes from ``model.simulate_batch`` at the
measurement times, so one call evaluates all the particles of a swarm (m parameter sets).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from aromm.core.clock import TIME_OFFSET, TimeShifted
from aromm.core.errors import InputError, NumericalError
from aromm.core.forward_model import ForwardModel
from aromm.core.observables import output_kind
from aromm.core.system import FloatArray
from inverse.measurements import Measurements


@dataclass(frozen=True)
class Scenario:
    """One experiment: a forward model and the measurements it should reproduce."""

    model: ForwardModel
    measurements: Measurements
    name: str = ""



ModelInput = ForwardModel | Sequence[tuple[ForwardModel, Measurements]]


def scenarios_of(model: ModelInput, measurements: Measurements | None,
                 parameters: Iterable[str] = ()) -> list[Scenario]:
    """One scenario (a model and its measurements), or the (model, measurements) pairs of a joint fit.

    When ``parameters`` (the unknown and fixed names) hold the clock offset ``time_offset``, every model that
    does not have it is wrapped in :class:`aromm.core.clock.TimeShifted` (one offset shared by every scenario).
    """
    if measurements is not None:
        if not isinstance(model, ForwardModel):
            raise InputError(f"model must be a forward model (FullModel, ReducedModel), got {type(model).__name__}")
        out = [Scenario(model, measurements)]
    elif isinstance(model, ForwardModel) or not isinstance(model, Sequence) or not model:
        raise InputError("give measurements, or a non-empty list of (model, measurements) pairs for a joint fit")
    else:
        out = []
        for i, pair in enumerate(model, start=1):
            if not (isinstance(pair, tuple) and len(pair) == 2 and isinstance(pair[0], ForwardModel)
                    and isinstance(pair[1], Measurements)):
                raise InputError(f"scenario {i}: expected a (model, measurements) pair, got {type(pair).__name__}")
            out.append(Scenario(pair[0], pair[1], str(i)))
    if TIME_OFFSET in set(parameters):
        out = [sc if TIME_OFFSET in sc.model.parameter_names else dataclasses.replace(sc, model=TimeShifted(sc.model))
               for sc in out]
    return out


class LeastSquares:
    """Residuals ``Y − Ŷ(β)`` and criterion ``J`` (eq. 12) for parameter sets ``β`` (rows of ``theta``).

    ``names`` are the unknowns (columns of ``theta``); ``fixed`` overrides other parameters of
    every model.  :attr:`evaluations` counts parameter sets evaluated (one per row).
    """

    def __init__(self, scenarios: Sequence[Scenario], names: Sequence[str],
                 fixed: Mapping[str, float] | None = None) -> None:
        if not scenarios:
            raise InputError("at least one (model, measurements) scenario is needed")
        self.scenarios = tuple(scenarios)
        self.names = tuple(names)
        self.fixed = dict(fixed or {})
        clash = set(self.names) & set(self.fixed)
        if clash:
            raise InputError(f"parameter(s) {sorted(clash)} are both unknown and fixed")
        for sc in self.scenarios:
            label = f"scenario {sc.name!r}: " if sc.name else ""
            known = sc.model.parameter_names
            for name in (*self.names, *self.fixed):
                if name not in known:
                    raise InputError(f"{label}unknown parameter {name!r}; the model has {sorted(known)}")
            sc.measurements.check_outputs(sc.model.outputs)
        self._columns = [np.array([sc.model.outputs.index(f) for f in sc.measurements.faces])
                         for sc in self.scenarios]
        self._data = [sc.measurements.as_array() for sc in self.scenarios]
        self.kinds = [np.array([output_kind(f) for f in sc.measurements.faces]) for sc in self.scenarios]
        self.weights = [np.ones(len(k)) for k in self.kinds]
        self.evaluations = 0

    def weigh(self, noise: Mapping[str, float]) -> None:
        """Weight every residual by 1/σ of its output's kind (``noise``: kind → σ, in the kind's unit)."""
        self.weights = [np.array([1.0 / noise[k] for k in kinds]) for kinds in self.kinds]

    def flat_weights(self) -> FloatArray:
        """The weight of every residual, in the order of :meth:`residuals`' columns."""
        return np.concatenate([np.broadcast_to(w, d.shape).ravel() for w, d in zip(self.weights, self._data,
                                                                                     strict=True)])

    @property
    def n_observations(self) -> int:
        return int(sum(d.size for d in self._data))

    def _params(self, theta: FloatArray) -> dict[str, FloatArray]:
        params: dict[str, FloatArray] = {k: np.full(theta.shape[0], float(v)) for k, v in self.fixed.items()}
        params.update({name: theta[:, j] for j, name in enumerate(self.names)})
        return params

    def start(self, theta: FloatArray) -> list[FloatArray]:
        """Ŷ at t = 0 (the initial temperatures) per scenario for one parameter set: (n_faces,) each."""
        params = self._params(np.atleast_2d(np.asarray(theta, dtype=float))[:1])
        return [np.asarray(sc.model.simulate_batch(params, [0.0]), dtype=float)[0, 0, cols]
                for sc, cols in zip(self.scenarios, self._columns, strict=True)]

    def predictions(self, theta: FloatArray) -> list[FloatArray]:
        """Ŷ per scenario, each (m, n_times, n_faces) in the measurements' face order."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        m = theta.shape[0]
        params = self._params(theta)
        out = []
        for sc, cols in zip(self.scenarios, self._columns, strict=True):
            y = np.asarray(sc.model.simulate_batch(params, sc.measurements.t), dtype=float)[:, :, cols]
            bad = ~np.all(np.isfinite(y), axis=(1, 2))
            if np.any(bad):
                where = dict(zip(self.names, theta[int(np.argmax(bad))].tolist(), strict=True))
                raise NumericalError(f"forward model {type(sc.model).__name__} returned non-finite temperatures "
                                     f"{'for scenario ' + repr(sc.name) + ' ' if sc.name else ''}at {where}")
            out.append(y)
        self.evaluations += m
        return out

    def misfits(self, theta: FloatArray) -> list[FloatArray]:
        """Unweighted ``Y − Ŷ`` per scenario (n_times, n_faces) for one parameter set ``theta`` (p,)."""
        preds = self.predictions(np.asarray(theta, dtype=float)[None])
        return [d - y[0] for d, y in zip(self._data, preds, strict=True)]

    def residuals(self, theta: FloatArray) -> FloatArray:
        """``w (Y − Ŷ)`` flattened over scenarios, times and faces: shape (m, n_observations)."""
        preds = self.predictions(theta)
        return np.concatenate([(w * (d[None] - y)).reshape(y.shape[0], -1)
                               for d, y, w in zip(self._data, preds, self.weights, strict=True)], axis=1)

    def __call__(self, theta: FloatArray) -> FloatArray:
        """J (eq. 12) for each row of ``theta``: shape (m,)."""
        r = self.residuals(theta)
        return 0.5 * np.einsum("ij,ij->i", r, r)
