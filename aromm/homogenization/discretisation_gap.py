"""How far the discretisation moves an identification's estimates: the default discretisation row of its budget.

On a voxel image the conforming trilinear elements (q1) overestimate the conductance of the voxel geometry and the
two-point finite volumes (fv) underestimate it, so the two bracket the resolved geometry's value
(docs/method/finite_volumes.md): k̄ 7–11 % apart on wood and fibre images.  An identification on one of them absorbs
that gap in the fitted phase conductivities.  Through k̄ alone the shift follows from the fit's structure: the model
reproduces the measurements at the estimates θ̂, so the other discretisation reproduces them (as far as k̄ decides
the outputs) where its k̄ equals the model's, ``k̄_other(λ θ̂_k) = k̄_model(θ̂_k)``, scaling the unknown phase
conductivities θ_k together by λ (the one direction of the fit that changes k̄ alone, as in
:mod:`aromm.homogenization.representativeness`).  λ is one Newton step in ln λ from λ = 1,
``ln λ = −ln(k̄_other / k̄_model) / S``, with the other's slope ``S = d ln k̄_other / d ln λ`` from the adjoint of its
steady probe (:func:`aromm.full.solve.steady_sensitivity`: one factorisation); against the secant method run to
2 % of the gap it stood within 0.99–1.02 on 6³–18³ images.  The slopes of the two differ (0.49 in fv against 0.73
in q1 on a 6³ image of walls crossed by the heat at contrast 12): the other's is taken, not the model's.  The
capacities do not move: both discretisations hold the same c̄ = Σ φ_i c_i.  Each unknown conductivity's half-width
is ``θ_j |ln λ|``, a bias (added linearly), the form of the shift of a re-fit with the other discretisation
(``identify --discretisation-check``, :func:`inverse.identification.alternative_shift`).

k̄ is the one the measurement sees: the fluxmetric conductivity under the scene's own faces [Chavez2020, eq. 13]
(:func:`aromm.homogenization.properties.fluxmetric`, the steady face means), so the scene must be such a scenario
(one face heated, the opposite one cooled).  The layers next to a heated face are where the two discretisations
differ most (fv's face temperature is half a cell from its voxel's centre, through that voxel's own conductivity;
q1's face nodes are shared between phases): on the wood generator's VER heated along its tracheids the cell
problem's k̄ (fixed temperatures on two faces) is the same in both while the estimate of k_F from the other's data
sits 0.11–0.64 from the truth in ln k (6³–18³).  So no other probe stands in where the fluxmetric one does not
apply: the row is then not estimated, and says so.
Measured against the re-fit by ``python benchmarks/discretisation_gap.py`` (record
benchmarks/records/discretisation_gap.txt).

Cost: a steady solve in the model's discretisation and a factorisation with three solves in the other, about
5 CPU s on the shipped 46³ VER (``aromm identify`` caches the row at the rounded estimates).  What it leaves out:
the transient part of the gap (the capacity matrix: consistent in q1, lumped in fv), which moves the capacities
too; the re-fit measures it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import dense
from aromm.full.solve import steady_sensitivity
from aromm.homogenization.properties import fluxmetric
from aromm.homogenization.representativeness import unknown_conductivities, with_values
from aromm.scene.model_section import refusal
from aromm.scene.scene_file import Scene, assemble


@dataclass(frozen=True)
class DiscretisationGap:
    """The fluxmetric k̄ (module docstring) at the estimates in the scene's discretisation (``k_model``) and in the
    other one (``k_other``), the other's slope ``S = d ln k̄ / d ln λ``, the factor λ (``scale``) on the unknown
    conductivities that gives the other the model's k̄, each unknown's relative half-width (``half``, by name) and
    the CPU seconds."""

    discretisation: str
    other: str
    k_model: float
    k_other: float
    slope: float
    scale: float
    half: Mapping[str, float]
    seconds: float

    def as_dict(self) -> dict[str, object]:
        return {"discretisation": self.discretisation, "other": self.other, "k_model": self.k_model,
                "k_other": self.k_other, "slope": self.slope, "scale": self.scale,
                "relative_half_width": dict(self.half), "cpu_seconds": self.seconds,
                "estimated_by": "one Newton step matching the other discretisation's fluxmetric k̄ to the "
                                "model's at the estimates"}

    def arrays(self) -> dict[str, np.ndarray]:
        """The entry of the cache kind ``discretisation-gap`` (``aromm identify`` keeps it)."""
        return {"k_model": np.array(self.k_model), "k_other": np.array(self.k_other), "slope": np.array(self.slope),
                "names": np.array(sorted(self.half)), "discretisations": np.array([self.discretisation, self.other]),
                "seconds": np.array(self.seconds)}

    @classmethod
    def from_arrays(cls, data: Mapping[str, np.ndarray]) -> DiscretisationGap:
        k_model, k_other, slope = (float(data[k]) for k in ("k_model", "k_other", "slope"))
        x = -math.log(k_other / k_model) / slope
        model, other = (str(d) for d in data["discretisations"])
        return cls(model, other, k_model, k_other, slope, math.exp(x), {str(n): abs(x) for n in data["names"]},
                   float(data["seconds"]))


#: Significant digits of the estimates at which the row is computed and cached (its own accuracy is ±15–45 %).
DIGITS = 6


def rounded(estimates: Mapping[str, float]) -> dict[str, float]:
    """The estimates to :data:`DIGITS` significant digits: the row is computed there, so that a cached row and a
    computed one are the same number."""
    return {n: float(f"{float(v):.{DIGITS}g}") for n, v in estimates.items()}


def discretisation_gap(scene: Scene, estimates: Mapping[str, float], method: str = "auto") -> DiscretisationGap:
    """The module docstring's relative half-widths for the unknowns ``estimates`` (name → value) of an
    identification on ``scene`` (a voxel scene); InputError (saying why) where it cannot be estimated: a mesh scene,
    an insulating phase where q1's system would be singular (:mod:`aromm.fem.insulation`), no unknown isotropic
    phase conductivity, not a heated/cooled scenario, no conducting path.  The estimates are first rounded to
    :data:`DIGITS` significant digits (:func:`rounded`).

    >>> import numpy as np
    >>> from aromm.core.vocabulary import FaceSpec, PhaseSpec
    >>> from aromm.scene.geometry import VoxelGeometry
    >>> labels = np.zeros((4, 4, 4), dtype=int); labels[:, :, 2:] = 1  # a laminate in series along z, heated on z0
    >>> s = Scene(VoxelGeometry(labels, (1e-3,) * 3), (PhaseSpec("a", 0, 1.0, 1e6), PhaseSpec("b", 1, 3.0, 1e6)),
    ...           (FaceSpec("z0", flux=100.0), FaceSpec("z1", h=10.0)))
    >>> g = discretisation_gap(s, {"a.k": 1.0}, method="splu")
    >>> round(g.k_model, 6), round(g.k_other, 6), round(g.half["a.k"], 6)  # both: the series value 2/(1 + 1/3)
    (1.5, 1.5, 0.0)
    """
    start = time.process_time()
    estimates = rounded(estimates)
    unknown_k, tensors = unknown_conductivities(scene, estimates)
    if not unknown_k:
        raise InputError("no unknown phase conductivity absorbs the gap of k̄ (it would move other parameters: "
                         "identify --discretisation-check re-fits to measure it)")
    if tensors:
        raise InputError(f"{tensors[0]} is an anisotropic phase's conductivity; the row scales isotropic ones only "
                         "(identify --discretisation-check re-fits instead)")
    other = "fv" if scene.discretisation == "q1" else "q1"
    refused = refusal(other, scene.geometry, scene.phases)
    if refused is not None:
        raise InputError(f"{other} cannot model this scene ({refused[0]}: {refused[1]})")
    base = with_values(scene, estimates)

    k_model = float(fluxmetric(base, method).k)  # InputError when the scene is not a heated/cooled scenario
    k_other, slope = _fluxmetric_slope(replace(base, discretisation=other), unknown_k, method)
    if k_model <= 0 or k_other <= 0 or slope <= 0:  # k̄ > 0 and rising in every conductivity wherever heat flows
        raise InputError(f"no conducting path at the estimates (k̄ {k_model:g} in {scene.discretisation}, {k_other:g} "
                         f"in {other}, slope {slope:g})")
    x = -math.log(k_other / k_model) / slope
    half = {name: abs(x) for name in unknown_k}
    return DiscretisationGap(scene.discretisation, other, k_model, k_other, slope, math.exp(x), half,
                             time.process_time() - start)


def _fluxmetric_slope(scene: Scene, unknown_k: Sequence[str], method: str) -> tuple[float, float]:
    """The fluxmetric k̄ of ``scene`` and ``S = d ln k̄ / d ln λ`` when its unknown conductivities are scaled by λ
    (the steady face means' adjoint sensitivities, :func:`aromm.full.solve.steady_sensitivity`)."""
    sensitivities: dict[str, tuple[float, float]] = {}

    def solve(probe: Scene) -> tuple[dict[str, float], float]:
        system = assemble(probe)
        names = list(system.observation)
        rows = np.vstack([dense(system.observation[n]).ravel() for n in names])
        values = {f"{ph.name}.k": float(ph.k)  # type: ignore[arg-type]
                  for ph in probe.phases if f"{ph.name}.k" in unknown_k}
        y, dy = steady_sensitivity(system, {}, rows, values, method=method)
        sensitivities.update({n: (float(a), float(b)) for n, a, b in zip(names, y, dy, strict=True)})
        return {n: v for n, (v, _) in sensitivities.items()}, 0.0

    probe = fluxmetric(scene, method, solve=solve)
    (hot, d_hot), (cold, d_cold) = sensitivities[probe.heated], sensitivities[probe.cooled]
    return float(probe.k), -(d_hot - d_cold) / (hot - cold)
