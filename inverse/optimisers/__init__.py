"""Optimisers of the identification, all in normalised coordinates ``u ∈ [0, 1]^p`` (:class:`Box`).

* :class:`ParticleSwarm` (pyswarms' backend, our own random generator) — the global search of
  [Chavez2020, § 4.1];
* :class:`LeastSquaresRefinement` (scipy trust-region least squares) — the local refinement;
* :class:`DifferentialEvolution` (scipy) — an alternative global search.

A new optimiser is one module: a class with a ``name`` and a ``run`` method (:class:`Optimiser`),
passed to :func:`inverse.identify` in its ``optimisers`` chain.
"""

from inverse.optimisers.box import Box
from inverse.optimisers.evolution import DifferentialEvolution
from inverse.optimisers.interface import Optimiser, Outcome, Problem, Step
from inverse.optimisers.least_squares import LeastSquaresRefinement, Refinement, jacobian, refine
from inverse.optimisers.swarm import ParticleSwarm, SwarmState, pso

__all__ = [
    "Box",
    "DifferentialEvolution",
    "LeastSquaresRefinement",
    "Optimiser",
    "Outcome",
    "ParticleSwarm",
    "Problem",
    "Refinement",
    "Step",
    "SwarmState",
    "jacobian",
    "pso",
    "refine",
]
