"""Repeated identifications on a task farm (:mod:`inverse.farm`): ``aromm identify --repeat N --farm ...``.

Repetition i runs :func:`inverse.identification.identify` with swarm seed ``seed + i`` on the measurements, plus,
when ``noise`` > 0, independent Gaussian noise of standard deviation ``noise`` (°C) drawn from
``np.random.default_rng(NOISE_SEED + seed + i)``: without noise the spread of the estimates is the optimiser's,
with noise a Monte-Carlo picture of what the noise does to them.  The model and the measurements travel once
per worker (:meth:`inverse.farm.Farm.map_shared`), the tasks carry two seeds each; the results are those of the
serial run, bit for bit, on every farm (tests/test_farm.py).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from aromm.core.errors import InputError
from aromm.core.forward_model import ForwardModel
from inverse.farm import Farm
from inverse.identification import DEFAULT_ITERATIONS, DEFAULT_PARTICLES, Identification, identify
from inverse.measurements import Measurements

NOISE_SEED = 1_000_000  # offset of the noise seeds from the swarm seeds


@dataclass(frozen=True)
class Problem:
    """What every repetition reads (sent once to each worker)."""

    model: ForwardModel
    measurements: Measurements
    unknowns: Mapping[str, tuple[float, float]]
    noise: float = 0.0
    particles: int = DEFAULT_PARTICLES
    iterations: int = DEFAULT_ITERATIONS
    description: Mapping[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class Repeat:
    """One repetition: its swarm seed and the seed of its noise."""

    index: int
    seed: int
    noise_seed: int


def run_one(problem: Problem, task: Repeat) -> Identification:
    """The identification of repetition ``task`` (module docstring)."""
    data = problem.measurements
    if problem.noise > 0:
        data = data.with_noise(problem.noise, np.random.default_rng(task.noise_seed))
    return identify(problem.model, data, problem.unknowns, seed=task.seed, particles=problem.particles,
                    iterations=problem.iterations, description=problem.description)


def repeated(problem: Problem, repeats: int, *, seed: int = 0, farm: Farm | None = None) -> list[Identification]:
    """``repeats`` identifications of ``problem`` spread over ``farm`` (default serial), in the order of i."""
    if repeats < 1:
        raise InputError(f"--repeat needs at least one repetition, got {repeats}")
    tasks = [Repeat(i, seed + i, NOISE_SEED + seed + i) for i in range(repeats)]
    return (farm or Farm()).map_shared(run_one, problem, tasks)


def summary(results: Sequence[Identification]) -> dict[str, dict[str, float]]:
    """Mean, standard deviation (ddof 1; 0 for one run), least and largest estimate of every unknown."""
    names = list(results[0].estimates)
    values = np.array([[r.estimates[n] for n in names] for r in results])
    std = values.std(axis=0, ddof=1) if len(results) > 1 else np.zeros(len(names))
    return {n: {"mean": float(values[:, j].mean()), "std": float(std[j]), "min": float(values[:, j].min()),
                "max": float(values[:, j].max())} for j, n in enumerate(names)}
