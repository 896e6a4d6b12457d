"""Defaults of the identification's budgets, in a module that imports nothing: the command line declares its
options from them without loading the optimisers (issue 37, item 4).

The particle swarm's ``DEFAULT_PARTICLES`` particles over ``DEFAULT_ITERATIONS`` iterations, then the least-squares
refinement [Chavez2020, § 4] (:mod:`inverse.identification`); ``DEFAULT_WALKERS`` walkers of the posterior's
ensemble sampler (:mod:`inverse.posterior`).
"""

from __future__ import annotations

DEFAULT_PARTICLES = 20
DEFAULT_ITERATIONS = 30
DEFAULT_WALKERS = 32
