"""A laboratory-style experiment on the wood VER of [Chavez2020] (issue 14): a heating pulse, an uncertain exchange
coefficient, a clock offset, thermocouples and a face patch.

The sample receives a 2 s flux pulse of 500 W/m² (0.1 s ramps) on z0 and exchanges with the air (T_ext = 0 °C)
on z1 through a coefficient h known only to ±30 % around 20 W/(m² K); it starts at 0 °C.  Three sensors
observe it (aromm.scene.sensors): thermocouples on the axis at a quarter and three quarters of the depth, and an IR
patch over the central quarter of z1.  The data logger's clock is off by δ = 0.2 s, and the readings carry
Gaussian noise of 0.02 °C.  The measurements are made by the full model (a finer time step, at the truth
k_F = 0.3 W/(m K), c_F = 4e6 J/(m³ K), h = 23 W/(m² K)); the unknowns k_F, c_F, h and δ are identified with
the reduced model (:func:`inverse.identify`), and their posterior is sampled
(:func:`inverse.posterior.sample_posterior`).

:func:`design_errors` compares designs by the linearised standard errors σ² (JᵀJ)⁻¹ at the truth (J the
sensitivities of the readings, every unknown included), as functions of the experiment's duration.

Used by ``notebooks/pulse_experiment.ipynb``; nothing in ``aromm`` or ``inverse`` imports it.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from aromm.core.clock import TIME_OFFSET, TimeShifted
from aromm.core.forward_model import ForwardModel
from aromm.core.profiles import Profile
from aromm.core.system import FloatArray, TimeGrid
from aromm.core.vocabulary import FaceSpec
from aromm.full.solve import FullModel
from aromm.scene.scene_file import Scene, assemble
from aromm.scene.sensors import FaceSensor, PointSensor, Sensor
from inverse.measurements import Measurements

FLUX = 500.0  # W/m², the amplitude of both designs
PULSE = Profile((0.0, 0.1, 2.0, 2.1), (0.0, FLUX, FLUX, 0.0))  # the 2 s pulse, ramps of 0.1 s
H_NOMINAL = 20.0  # W/(m² K): the scene's value, the reduced model's reference
END, DT = 20.0, 0.1  # s: duration and reading interval
NOISE = 0.02  # °C, standard deviation of every reading
TRUTH: Mapping[str, float] = {"fibre.k": 0.3, "fibre.c": 4.0e6, "z1.h": 23.0, TIME_OFFSET: 0.2}
UNKNOWNS: Mapping[str, tuple[float, float]] = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7),
                                               "z1.h": (0.7 * H_NOMINAL, 1.3 * H_NOMINAL), TIME_OFFSET: (-0.5, 0.5)}


def sensors(size: Sequence[float]) -> tuple[Sensor, ...]:
    """Two thermocouples on the axis (depths L/4 and 3L/4) and an IR patch over the central quarter of z1."""
    lx, ly, lz = size
    return (PointSensor("tc_front", (lx / 2, ly / 2, lz / 4)), PointSensor("tc_back", (lx / 2, ly / 2, 3 * lz / 4)),
            FaceSensor("patch_back", "z1", ((lx / 4, 3 * lx / 4), (ly / 4, 3 * ly / 4))))


def experiment(material: Scene, flux: float | Profile = PULSE, end: float = END, dt: float = DT) -> Scene:
    """``material`` heated by ``flux`` (W/m², or a history) on z0, cooled by h = 20 W/(m² K) on z1, observed by
    :func:`sensors` only."""
    faces = (FaceSpec("z0", flux=flux), FaceSpec("z1", h=H_NOMINAL, T_ext=0.0))
    return replace(material.with_boundary(faces, (), TimeGrid(end, dt)), sensors=sensors(material.size))


def measurements(scene: Scene, rng: np.random.Generator, truth: Mapping[str, float] = TRUTH,
                 noise: float = NOISE, refine_dt: int = 5) -> tuple[Measurements, Measurements, float]:
    """Readings every ``dt`` of the scene from the full model at ``truth`` (clock offset included) with Gaussian
    ``noise``, the same without noise, and the full model's CPU seconds.

    The full model runs at dt / ``refine_dt`` and at half that step, Richardson-extrapolated (BDF2 is second
    order), on a grid long enough for the offset, so the readings' own time-step error is far below the noise.
    """
    assert scene.time is not None
    system = assemble(scene)
    start = time.process_time()
    runs = [TimeShifted(FullModel(replace(system, time=TimeGrid(scene.time.end + 1.0, scene.time.dt / k)))).simulate(
        dict(truth), scene.time.times).as_array() for k in (refine_dt, 2 * refine_dt)]
    seconds = time.process_time() - start
    clean = runs[1] + (runs[1] - runs[0]) / 3.0
    data = Measurements(scene.time.times, {name: clean[:, j] for j, name in enumerate(system.observation)},
                        source="pulse experiment (full model)")
    return data.with_noise(noise, rng), data, seconds


def sensitivities(model: ForwardModel, point: Mapping[str, float], times: FloatArray,
                  rel_step: float = 1e-4, offset_step: float = 1e-3) -> FloatArray:
    """∂(readings)/∂(unknowns) at ``point`` by central differences (``model`` wrapped for the clock offset):
    shape (len(times) × outputs, unknowns); steps ``rel_step`` relative, ``offset_step`` s for δ."""
    shifted = TimeShifted(model)
    names = list(point)
    steps = np.array([offset_step if n == TIME_OFFSET else rel_step * abs(point[n]) for n in names])
    batch = {n: np.full(2 * len(names), point[n], dtype=float) for n in names}
    for j, n in enumerate(names):
        batch[n][2 * j] += steps[j]
        batch[n][2 * j + 1] -= steps[j]
    y = shifted.simulate_batch(batch, times)
    return np.column_stack([(y[2 * j] - y[2 * j + 1]).ravel() / (2 * steps[j]) for j in range(len(names))])


@dataclass(frozen=True)
class Design:
    """Linearised standard errors of the unknowns for one design and duration."""

    name: str
    duration: float
    std_error: Mapping[str, float]


def design_errors(name: str, model: ForwardModel, durations: Sequence[float], *, truth: Mapping[str, float] = TRUTH,
                  noise: float = NOISE, dt: float = DT) -> list[Design]:
    """σ² (JᵀJ)⁻¹ at ``truth`` for readings every ``dt`` up to each duration (every unknown of ``truth``)."""
    out = []
    for d in durations:
        times = dt * np.arange(1, round(d / dt) + 1, dtype=float)
        jac = sensitivities(model, truth, times)
        cov = noise**2 * np.linalg.inv(jac.T @ jac)
        out.append(Design(name, float(d), {n: float(np.sqrt(cov[i, i])) for i, n in enumerate(truth)}))
    return out
