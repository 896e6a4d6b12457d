"""Local refinement by trust-region least squares (scipy), and the sensitivities by central differences.

From the best point of a global search, ``scipy.optimize.least_squares`` (trust-region reflective, inside
``[0, 1]^p``) minimises J = ½‖r‖² [Chavez2020, eq. 12] with the Jacobian of :func:`jacobian`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.optimize as so

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from inverse.optimisers.interface import Outcome, Problem, Residuals, State, Step

FD_STEP = 1e-5  # central-difference step in normalised coordinates


def jacobian(residuals: Residuals, u: FloatArray, step: float = FD_STEP) -> FloatArray:
    """d r / d u (N, p) by central differences in one batch, the stencil clipped to ``[0,1]``."""
    u = np.asarray(u, dtype=float)
    p = u.size
    plus = np.clip(u + step * np.eye(p), 0.0, 1.0)
    minus = np.clip(u - step * np.eye(p), 0.0, 1.0)
    r = residuals(np.vstack([plus, minus]))
    width = np.diag(plus - minus)
    return np.asarray(((r[:p] - r[p:]) / width[:, None]).T)


@dataclass(frozen=True)
class Refinement:
    """Result of the local least-squares refinement (normalised coordinates)."""

    u: FloatArray
    cost: float
    evaluations: int
    message: str


def refine(residuals: Residuals, u0: FloatArray, *, max_iterations: int = 50,
           callback: Callable[[float], None] | None = None) -> Refinement:
    """Trust-region reflective least squares (scipy) from ``u0`` inside ``[0,1]^p``.

    Tolerances: relative change of cost, of ``u`` and of the gradient below 1e-12.  ``callback``
    receives the criterion J = ½‖r‖² after each residual evaluation.
    """
    count = 0

    def fun(u: FloatArray) -> FloatArray:
        nonlocal count
        r = residuals(u[None])[0]
        count += 1
        if callback is not None:
            callback(0.5 * float(r @ r))
        return r

    def jac(u: FloatArray) -> FloatArray:
        nonlocal count
        count += 2 * u.size
        return jacobian(residuals, u)

    start = np.clip(np.asarray(u0, dtype=float), 0.0, 1.0)
    sol = so.least_squares(fun, start, jac=jac, bounds=(0.0, 1.0), method="trf", ftol=1e-12, xtol=1e-12,
                           gtol=1e-12, max_nfev=max_iterations)
    return Refinement(np.asarray(sol.x), float(sol.cost), count, str(sol.message))


@dataclass(frozen=True)
class LeastSquaresRefinement:
    """:func:`refine` as a chain link of :func:`inverse.identify`: starts from the previous optimiser's best.

    It holds no state worth saving (a few evaluations): an interrupted refinement starts again.
    """

    max_iterations: int = 50
    name: str = "refine"

    def run(self, problem: Problem, start: FloatArray | None, rng: np.random.Generator, *,
            state: State | None = None, callback: Callable[[Step], None] | None = None) -> Outcome:
        if start is None:
            raise InputError("the least-squares refinement needs a starting point (put a global search before it)")
        steps = 0

        def report(cost: float) -> None:
            nonlocal steps
            steps += 1
            if callback is not None:
                callback(Step(steps, 0, cost))

        local = refine(problem.residuals, start, max_iterations=self.max_iterations, callback=report)
        return Outcome(local.u, local.cost, local.evaluations, local.message)
