"""The identification study of [Chavez2020, § 4]: Table 2, the +2 % study, and accuracy against cost.

Shared by ``notebooks/table2.ipynb`` and ``benchmarks/identify.py``.  Equation numbers are those of
[Chavez2020].  The measurements of a
scenario come from the homogeneous orthotropic twin (k̄ by eq. 13 applied as § 4.2 does, i.e. under
that scenario's own faces: :func:`aromm.fluxmetric`; c̄ by eq. 14) and the
unknowns k_F, c_F of the heterogeneous model are searched in the bounds of :data:`UNKNOWNS`;
the error of an estimate is eq. 15, ``σ = |β̂ − β| / β``, against the scene's own fibre values.
Loading directions follow docs/design.md: scenario 1 heats z0 (Table 2 row "zz"), 2 heats x0
("xx"), 3 heats y0 ("yy").
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aromm.core.forward_model import ForwardModel
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec
from aromm.homogenization.properties import fluxmetric, mean_capacity
from aromm.homogenization.synthetic import homogeneous_measurements
from aromm.reduction.offline import reduce
from aromm.reduction.rom import ReducedModel
from aromm.scene.scene_file import Scene, assemble, load_scene, scene_from_dict
from inverse import optimisers as opt
from inverse.criterion import LeastSquares, Scenario
from inverse.farm import Farm
from inverse.identification import DEFAULT_ITERATIONS, DEFAULT_PARTICLES, Identification, identify
from inverse.measurements import Measurements

UNKNOWNS: Mapping[str, tuple[float, float]] = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}
AXES = ("x", "y", "z")
SCENE_FILES = {"z": "wood_s1.toml", "x": "wood_s2.toml", "y": "wood_s3.toml"}

#: Reference properties of the reduced model [Chavez2020, § 3.1–3.2]: modal bases at BASIS_VALUES, the amalgam's
#: reference simulation at REFERENCE_VALUES (what the shipped scenes' ``[reduction]`` sections say).
BASIS_VALUES: Mapping[str, float] = {"fibre.k": 0.53, "fibre.c": 1.2e6}
REFERENCE_VALUES: Mapping[str, float] = {"fibre.k": 0.1, "fibre.c": 1.2e6}

#: [Chavez2020] Table 2 by loading direction: k̂_F (W/(m K)), σ_k (%), ĉ_F (J/(m^3 K)), σ_c (%), t_CPU (h).
PAPER_TABLE2: Mapping[str, tuple[float, float, float, float, float]] = {
    "x": (0.299, 0.230, 4.051e6, 1.276, 4.1),
    "y": (0.298, 0.798, 4.042e6, 1.052, 5.2),
    "z": (0.296, 1.290, 4.048e6, 1.212, 3.6),
}
#: [Chavez2020, § 4.3]: errors (%) when every homogeneous property is 2 % too high (loading along x).
PAPER_PERTURBED: Mapping[str, float] = {"fibre.k": 2.9, "fibre.c": 3.3}
#: [Chavez2020, § 4.2]: k̄_xx, k̄_yy, k̄_zz (W/(m K)) and c̄ (J/(m^3 K)) for k_F = 0.3, c_F = 4e6.
PAPER_HOMOGENEOUS = (0.087, 0.099, 0.123, 1.558e6)


def relative_errors(estimates: Mapping[str, float], truth: Mapping[str, float]) -> dict[str, float]:
    """Eq. 15, ``σ_β = |β̂ − β| / β``, for every parameter of ``truth``."""
    return {k: abs(float(estimates[k]) - v) / abs(v) for k, v in truth.items()}


def fibre_truth(scene: Scene) -> dict[str, float]:
    """The fibre values the scene was built with: what an identification should find."""
    fibre = next(ph for ph in scene.phases if ph.name == "fibre")
    return {"fibre.k": float(fibre.k), "fibre.c": float(fibre.c)}  # type: ignore[arg-type]


def loading(material: Scene, axis: str, *, end: float = 60.0, dt: float = 0.1, flux: float = 500.0,
            h: float = 20.0) -> Scene:
    """Table 1 of [Chavez2020] on ``material``: ``flux`` (W/m²) into face <axis>0, ``h`` (W/(m² K)) on <axis>1."""
    faces = (FaceSpec(f"{axis}0", flux=flux), FaceSpec(f"{axis}1", h=h, T_ext=0.0))
    return material.with_boundary(faces, (f"{axis}0", f"{axis}1"), TimeGrid(end, dt))


def small_wood(n: int = 12, box: float = 230e-6, seed: int = 0) -> Scene:
    """A coarse spruce-like VER: ``n``³ voxels over the paper's ``box`` (m) with its phase properties.

    The tracheid cross-section (25 x 35 µm cells, 5 µm walls at 5 µm voxels) is scaled with the
    voxel so that walls stay one voxel thick and the fibre fraction stays near the shipped VER's.
    """
    return scene_from_dict({
        "geometry": small_wood_geometry(n, box, seed),
        "phases": {"fibre": {"label": 1, "k": 0.3, "c": 4.0e6}, "gas": {"label": 0, "k": 0.025, "c": 1.2e3}},
        "reduction": {"basis": dict(BASIS_VALUES), "reference": dict(REFERENCE_VALUES)},
    })


def small_wood_geometry(n: int = 12, box: float = 230e-6, seed: int = 0) -> dict[str, Any]:
    """The ``[geometry]`` section of :func:`small_wood` (the wood generator's keys and values)."""
    voxel = box / n
    scale = voxel / 5e-6
    return {"generator": "wood", "shape": [n, n, n], "voxel_size": voxel, "seed": seed,
            "cell_size_radial": 25e-6 * scale, "cell_size_tangential": 35e-6 * scale, "wall_thickness": 5e-6 * scale}


def scenario_1_text(geometry: str, *, end: float | str = 60.0, dt: float | str = 0.1) -> str:
    """Scenario 1 of [Chavez2020, Table 1] as scene-file text, for command-line runs on a generated or saved image.

    ``geometry``: the lines of the ``[geometry]`` section; fibre (label 1, k = 0.3 W/(m K), c = 4e6 J/(m³ K)) and gas
    (label 0, 0.025, 1.2e3); 500 W/m² into z0, h = 20 W/(m² K) to 0 °C on z1, T0 = 0 °C; outputs every ``dt`` to
    ``end`` (s, or TOML literals).

    >>> import tomllib
    >>> sorted(tomllib.loads(scenario_1_text('image = "wood.npy"\\nvoxel_size = 5e-6'))["boundary"])
    ['z0', 'z1']
    """
    return f"""
[geometry]
{geometry}

[phases.fibre]
label = 1
k = 0.3
c = 4.0e6

[phases.gas]
label = 0
k = 0.025
c = 1.2e3

[boundary.z0]
flux = 500.0
[boundary.z1]
h = 20.0
T_ext = 0.0

[initial]
T = 0.0

[time]
end = {end}
dt = {dt}

[outputs]
mean_T = ["z0", "z1"]
"""


def shipped_scenarios(root: Path) -> dict[str, Scene]:
    """The three scenario scenes of the shipped wood VER (``data/scenes/wood_s{1,2,3}.toml``)."""
    return {axis: load_scene(root / "data" / "scenes" / SCENE_FILES[axis]) for axis in AXES}


@dataclass(frozen=True)
class Case:
    """One loading direction: its scene, assembled heterogeneous system and twin measurements."""

    axis: str
    scene: Scene
    system: ThermalSystem
    measurements: Measurements


def reduced(case: Case, order: int, **options: Any) -> ReducedModel:
    """The reduced model of a case at the scene's ``[reduction]`` reference values (:func:`aromm.reduce`), by the
    papers' method (the amalgam) unless ``options`` name another."""
    method = options.pop("method", "aromm")
    return reduce(case.system, order, settings=case.scene.reduction.updated(method=method), **options)


@dataclass(frozen=True)
class Homogeneous:
    """k̄_ii per loading axis i (W/(m K), eq. 13 under each scenario), c̄ (J/(m^3 K), eq. 14), seconds taken."""

    k: Mapping[str, float]
    c: float
    seconds: float


def homogeneous_properties(scenes: Mapping[str, Scene], method: str = "auto") -> Homogeneous:
    """k̄ of every scenario by :func:`aromm.fluxmetric` (linear solver ``method``), c̄ by eq. 14.

    The scenarios share one material, so c̄ is taken from the first.
    """
    start = time.perf_counter()
    k = {axis: fluxmetric(sc, method=method).k for axis, sc in scenes.items()}
    return Homogeneous(k, mean_capacity(next(iter(scenes.values()))), time.perf_counter() - start)


def twin_cases(scenes: Mapping[str, Scene], hom: Homogeneous, perturbation: float = 0.0) -> dict[str, Case]:
    """Measurements of every scenario from its homogeneous twin (properties × (1 + perturbation))."""
    return {axis: Case(axis, sc, assemble(sc),
                       homogeneous_measurements(sc, hom.k[axis], hom.c, perturbation=perturbation))
            for axis, sc in scenes.items()}


@dataclass(frozen=True)
class Run:
    """One identification and its errors (eq. 15, fractions) against the truth."""

    label: str
    result: Identification
    errors: Mapping[str, float]
    cpu: float = 0.0  # CPU seconds of the identification call (process_time)

    def row(self) -> dict[str, object]:
        unc = self.result.uncertainty
        out: dict[str, object] = {"run": self.label}
        for i, name in enumerate(unc.names):
            out[name] = self.result.estimates[name]
            if name in self.errors:
                out[f"err {name} %"] = 100 * self.errors[name]
            out[f"se {name} %"] = 100 * float(unc.std_error[i]) / abs(self.result.estimates[name])
        out["J"] = self.result.criterion
        out["evaluations"] = self.result.evaluations
        out["seconds"] = self.result.seconds
        out["CPU s"] = self.cpu
        return out


def run(label: str, model: ForwardModel | Sequence[tuple[ForwardModel, Measurements]],
        measurements: Measurements | None, truth: Mapping[str, float], *,
        unknowns: Mapping[str, tuple[float, float]] = UNKNOWNS, seed: int = 0,
        particles: int = DEFAULT_PARTICLES, iterations: int = DEFAULT_ITERATIONS, refine: bool = True,
        description: Mapping[str, object] | None = None) -> Run:
    """:func:`inverse.identify()` with the study's bounds, and the errors of its estimates."""
    cpu = time.process_time()
    result = identify(model, measurements, unknowns, seed=seed, particles=particles, iterations=iterations,
                      refine=refine, description=description)
    return Run(label, result, relative_errors(result.estimates, truth), time.process_time() - cpu)


@dataclass(frozen=True)
class Repetition:
    """One identification of a farm of repetitions: ``noise_seed`` draws the noise, ``seed`` the swarm."""

    label: str
    noise: float
    noise_seed: int
    seed: int


@dataclass(frozen=True)
class Repeated:
    """What every repetition reads, sent once to each worker of the farm (inverse.farm.Farm.map_shared)."""

    model: ForwardModel
    exact: Measurements
    truth: Mapping[str, float]
    particles: int = DEFAULT_PARTICLES
    iterations: int = DEFAULT_ITERATIONS


def run_repetition(problem: Repeated, task: Repetition) -> Run:
    """:func:`run` on ``problem.exact`` plus Gaussian noise of standard deviation ``task.noise`` (°C)."""
    data = (problem.exact.with_noise(task.noise, np.random.default_rng(task.noise_seed)) if task.noise > 0
            else problem.exact)
    return run(task.label, problem.model, data, problem.truth, seed=task.seed, particles=problem.particles,
               iterations=problem.iterations)


def noisy_repetitions(model: ForwardModel, exact: Measurements, truth: Mapping[str, float], *, reps: int,
                      noise: float, particles: int = DEFAULT_PARTICLES, iterations: int = DEFAULT_ITERATIONS,
                      farm: Farm | None = None, first_noise_seed: int = 1000) -> list[Run]:
    """``reps`` identifications from noisy copies of ``exact`` (noise seed ``first_noise_seed + rep``, swarm
    seed ``rep``), spread over ``farm`` (inverse.farm; default serial; the model travels once per worker); the
    same results whatever the farm."""
    tasks = [Repetition(f"rep {rep}", noise, first_noise_seed + rep, rep) for rep in range(reps)]
    return (farm or Farm()).map_shared(run_repetition, Repeated(model, exact, dict(truth), particles, iterations),
                                       tasks)


def refine_from(label: str, model: ForwardModel, measurements: Measurements, start: Mapping[str, float],
                truth: Mapping[str, float], *, unknowns: Mapping[str, tuple[float, float]] = UNKNOWNS,
                max_iterations: int = 12) -> dict[str, object]:
    """Least-squares refinement alone (no swarm) from ``start``: for models too costly for a swarm.

    E.g. the full model on the shipped VER, started from a reduced-model estimate.
    """
    box = opt.Box.from_bounds(unknowns)
    criterion = LeastSquares([Scenario(model, measurements)], box.names)
    begin = time.perf_counter()
    local = opt.refine(lambda u: criterion.residuals(box.to_physical(u)),
                   box.to_unit(np.array([start[n] for n in box.names])), max_iterations=max_iterations)
    estimates = dict(zip(box.names, box.to_physical(local.u).tolist(), strict=True))
    errors = relative_errors(estimates, truth)
    out: dict[str, object] = {"run": label}
    for name in box.names:
        out[name] = estimates[name]
        out[f"err {name} %"] = 100 * errors[name]
    out.update({"J": local.cost, "evaluations": criterion.evaluations, "seconds": time.perf_counter() - begin,
                "stop": local.message})
    return out


def budget_sweep(model: ForwardModel, measurements: Measurements, truth: Mapping[str, float],
                 budgets: Sequence[tuple[int, int]], seed: int = 0) -> list[Run]:
    """Error against swarm budget (particles, iterations), each without and with the local refinement."""
    out = []
    for particles, iterations in budgets:
        for refine in (False, True):
            label = f"PSO {particles}x{iterations}{' + refine' if refine else ''}"
            out.append(run(label, model, measurements, truth, seed=seed, particles=particles, iterations=iterations,
                           refine=refine))
    return out


def as_table(rows: Sequence[Mapping[str, object]]) -> str:
    """Rows of dicts as a fixed-width text table (numbers with 4 significant digits)."""
    keys: list[str] = []
    for r in rows:
        keys.extend(k for k in r if k not in keys)

    def cell(v: object) -> str:
        if isinstance(v, float | np.floating):
            return f"{float(v):.4g}"
        return "" if v is None else str(v)

    cells = [[cell(r.get(k)) for k in keys] for r in rows]
    widths = [max(len(k), *(len(c[i]) for c in cells)) for i, k in enumerate(keys)]
    lines = ["  ".join(k.rjust(w) for k, w in zip(keys, widths, strict=True))]
    lines += ["  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(lines)
