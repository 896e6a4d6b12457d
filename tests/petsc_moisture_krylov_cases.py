"""Cases of the petsc engine's Krylov reduced model of coupled heat and moisture (method="krylov", engine="petsc":
the coupled shifted solves by CG + GAMG on the diagonally scaled operator, block size 2), computed the same way at 1
rank in the pytest process and under ``mpiexec`` (``petsc_worker.py OUT.npz petsc_moisture_krylov_cases``).

The scene is :mod:`petsc_moisture_cases`' 6×5×4 two-phase image with natural conditions only (the petsc engine's
reductions lift no fixed value): z0 exchanges heat and vapour with humid air (φ_ext 0.8, the step of the full-model
cases' fixed φ), z1 takes a heat and a moisture flux, x1 exchanges heat and vapour with dry air; T0 = 20 °C, φ0 = 0.5
(the coupled initial state's φ part is an initial term, ``initial.phi − initial.T`` on φ).  The greedy runs over
:data:`BOX` (one thermal, one moisture property), certified (its Gram matrices by the
same scaled solves, summed over the ranks).  Q1 (the coupled fv Krylov model is checked against the exact model on
the scipy engine, tests/test_stiff_pencils.py)."""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Any

import numpy as np
import petsc_moisture_cases as moisture

import aromm
from aromm.core.errors import ModelWarning
from aromm.core.vocabulary import FaceSpec
from aromm.reduction.krylov import KrylovReductor
from aromm.scene.scene_file import Scene, assemble

#: The training box, around :data:`petsc_moisture_cases.PROBE`.
BOX = {"fibre.k": (0.2, 0.6), "gas.D_phi": (5e-10, 5e-9)}
#: Where the models are compared: the probe, and the box's slow corner.
POINTS = (moisture.PROBE, {"fibre.k": 0.2, "gas.D_phi": 5e-10})
#: The model's tolerance (°C, on T and on φ alike): the greedy's 2 points (3 shifts each) reach ≈ 1e-4.
TOLERANCE = 1e-3
#: Relative residual of the shifted solves (both engines; the scipy engine's are direct and checked against it).
RTOL = 1e-12


def scene(discretisation: str = "q1") -> Scene:
    """:func:`petsc_moisture_cases.transient_scene` with z0's fixed T and φ replaced by heat and vapour exchange with
    air at 20 °C and φ 0.8 (module docstring)."""
    case = moisture.transient_scene(discretisation)
    assert case.moisture is not None
    boundary = (FaceSpec("z0", h=50.0, T_ext=20.0), *(f for f in case.boundary if f.face != "z0"))
    wet = replace(case.moisture, fixed_phi={}, vapour={**case.moisture.vapour, "z0": (1e-7, 0.8)})
    return replace(case, boundary=boundary, moisture=wet)


def build(engine: str) -> aromm.ReducedModel:
    """The certified Krylov model of :func:`scene` (Q1) on ``engine`` (``"petsc"``: the scene read by boxes), its
    whole span (no compression: the engines' spans compared, not a compression's choices)."""
    case = scene()
    source = case if engine == "petsc" else assemble(case)
    options = {"engine": "petsc"} if engine == "petsc" else {}
    reductor = KrylovReductor.over(BOX, max_points=2, shifts=3, tolerance=TOLERANCE, rtol=RTOL, certify=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)  # its bound, not its error, misses the tolerance at 2 points
        return aromm.reduce(source, 10_000, method=reductor, cache=False, **options)


def record(rom: aromm.ReducedModel) -> dict[str, np.ndarray]:
    """Outputs (T and φ) and certified bounds at :data:`POINTS` (also without the rounding spread of the Gram matrices'
    residuals, which the petsc engine forms in float64 and the scipy engine in extended precision), the output names,
    the order and the greedy's points."""
    assert rom.certificate is not None and rom.certificate.spread is not None
    unspread = replace(rom, certificate=replace(rom.certificate, spread=np.zeros_like(rom.certificate.spread)))
    return {"outputs": np.stack([rom.simulate(p).as_array() for p in POINTS]),
            "bound": np.stack([_bound(rom, p) for p in POINTS]),
            "unspread": np.stack([_bound(unspread, p) for p in POINTS]),
            "names": np.array(list(rom.outputs)),
            "span": np.array([rom.order, rom.info["krylov_points"]])}


def _bound(rom: aromm.ReducedModel, point: dict[str, float]) -> np.ndarray:
    bound = rom.error_bound(point)
    return np.full(len(rom.outputs), np.nan) if bound is None else bound


def condition() -> float:
    """The largest 2-norm condition number over :data:`POINTS` of the diagonally scaled ``K(μ)`` (the shift s = 0,
    the least definite of the shifted operators ``K + s C`` the reductor solves), as the petsc engine solves a coupled
    system (aromm.engines.petsc.linear.scale_symmetrically)."""
    system = assemble(scene())
    out = 0.0
    for point in POINTS:
        k = system.conductance.evaluate(system.values(point)).toarray()
        scale = 1.0 / np.sqrt(np.diag(k))
        out = max(out, float(np.linalg.cond(scale[:, None] * k * scale[None, :])))
    return out


def results(comm: Any) -> dict[str, np.ndarray]:
    """The model on the petsc engine (collective)."""
    return record(build("petsc"))


def serial() -> dict[str, np.ndarray]:
    """The same model by the scipy engine (direct solves)."""
    return record(build("scipy"))
