"""Global search by differential evolution [StornPrice1997] (scipy), an alternative to the particle swarm.

``scipy.optimize.differential_evolution`` with the whole population evaluated in one call (vectorised),
polished by nothing (put a :class:`~inverse.optimisers.least_squares.LeastSquaresRefinement` after it).
Its random draws come from the given generator.  It cannot be resumed mid-run: an interrupted search
starts again.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aromm.core.system import FloatArray
from inverse.optimisers.interface import Outcome, Problem, State, Step


@dataclass(frozen=True)
class DifferentialEvolution:
    """``population`` × dim members per generation, at most ``generations`` generations."""

    population: int = 15
    generations: int = 30
    tolerance: float = 1e-8
    name: str = "differential-evolution"

    def run(self, problem: Problem, start: FloatArray | None, rng: np.random.Generator, *,
            state: State | None = None, callback: Callable[[Step], None] | None = None) -> Outcome:
        import scipy.optimize as so  # only for this optimiser (≈ 0.13 CPU s of every identify otherwise)

        generation = 0

        def report(intermediate_result: so.OptimizeResult) -> None:  # scipy passes the result by this name
            nonlocal generation
            generation += 1
            if callback is not None:
                callback(Step(generation, self.generations, float(intermediate_result.fun)))

        def cost(u: FloatArray) -> FloatArray:
            return problem.costs(np.asarray(u).T)  # scipy passes (dim, m) when vectorised

        sol = so.differential_evolution(cost, [(0.0, 1.0)] * problem.dim, popsize=self.population,
                                        maxiter=self.generations, tol=self.tolerance, polish=False, vectorized=True,
                                        updating="deferred", rng=rng, x0=start, callback=report)
        return Outcome(np.asarray(sol.x), float(sol.fun), int(sol.nfev), str(sol.message))
