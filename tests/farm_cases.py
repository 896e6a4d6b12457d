"""Repeated identifications shared by tests/test_farm.py and its MPI worker: a 4³ full model, 3 noisy copies."""

from __future__ import annotations

import numpy as np

from aromm.full.solve import FullModel
from aromm.studies.chavez2020 import noisy_repetitions
from inverse.farm import Farm
from inverse.measurements import simulate_measurements

TRUTH = {"fibre.k": 0.3, "fibre.c": 4.0e6}


def estimates(farm: Farm) -> np.ndarray:
    """(reps, 2) estimates of k_F, c_F from noisy twin data, PSO 4 × 2 + refinement, through ``farm``."""
    from inverse_cases import scenario_system

    model = FullModel(scenario_system("z", n=4, end=20.0, dt=2.0))
    exact = simulate_measurements(model, TRUTH, model.default_times)
    runs = noisy_repetitions(model, exact, TRUTH, reps=3, noise=0.01, particles=4, iterations=2, farm=farm)
    return np.array([[r.result.estimates[k] for k in TRUTH] for r in runs])


#: Pickles of :class:`Counted` made in this process (the parent of the farm's workers).
PICKLED = [0]


class Counted:
    """A payload that counts its pickles in the process that pickles it."""

    def __init__(self, payload: float) -> None:
        self.payload = payload

    def __reduce__(self) -> tuple[type, tuple[float]]:
        PICKLED[0] += 1
        return (Counted, (self.payload,))


def scaled(shared: Counted, task: int) -> float:
    return shared.payload * task


#: ``aromm identify`` options of the --repeat runs: the full model, a small swarm, noise of 0.05 °C.
REPEAT = ["--unknown", "fibre.k=0.05:1", "--unknown", "fibre.c=1e5:1e7", "--model", "full", "--particles", "4",
          "--iterations", "2", "--repeat", "3", "--repeat-noise", "0.05", "--json"]
