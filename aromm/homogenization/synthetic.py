"""Synthetic measurements from the homogeneous orthotropic twin of a scene [Chavez2020, eq. 1, § 4.2].

The paper's measurements come from the *homogeneous orthotropic* twin of the sample: one phase of conductivity
diag(k̄_xx, k̄_yy, k̄_zz) (eq. 13) and capacity c̄ (eq. 14) on the same box under the same scenario.  The result is
the toolkit's one time-series table (:class:`aromm.core.observables.Observables`), which :mod:`inverse` reads as
measurements.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.observables import Observables
from aromm.full.solve import simulate
from aromm.homogenization.properties import homogeneous_twin
from aromm.physics.hygrothermal import MoistureState
from aromm.scene.scene_file import Scene, assemble


def homogeneous_measurements(scene: Scene, k: npt.ArrayLike, c: float, *, perturbation: float = 0.0,
                             method: str = "auto", moisture: Mapping[str, float] | None = None) -> Observables:
    """Face means of the homogeneous orthotropic twin of ``scene`` [Chavez2020, eq. 1, § 4.2].

    ``k`` is the effective conductivity (W/(m K)): a 3x3 tensor (``aromm.homogenize``) or, for a
    scenario loaded along one axis, the scalar ``aromm.fluxmetric(scene).k`` ([Chavez2020]
    § 4.2; the unloaded axes carry no heat); ``c`` the mean capacity (J/(m^3 K);
    ``aromm.mean_capacity(scene)``, eq. 14).  Every homogeneous property is multiplied by
    ``1 + perturbation`` (§ 4.3 studies +2 %: 0.02).  The twin (``aromm.homogeneous_twin``) has the
    scene's box, face conditions, time grid and outputs; it is simulated by the full model
    with the linear solver ``method``.  A scene with ``[moisture]`` needs ``moisture``, the twin's ``xi``, ``D_phi``
    and ``delta_p`` (:func:`moisture_twin`; scaled like the others).
    """
    if scene.time is None:
        raise InputError(f"{scene.where}measurements need a transient scene ([time] with end and dt)")
    if not (math.isfinite(perturbation) and perturbation > -1):
        raise InputError(f"perturbation must be a finite fraction > -1, got {perturbation!r}")
    scale = 1.0 + perturbation
    twin = homogeneous_twin(scene, scale * np.asarray(k, dtype=float), scale * float(c))
    if scene.moisture is not None:
        if moisture is None:
            raise InputError(f"{scene.where}moisture: the homogeneous twin needs its moisture properties")
        diag = np.diag(np.asarray(k, dtype=float) * np.eye(3))
        if np.ptp(diag) > 0:
            raise InputError(f"{scene.where}moisture: the coupled twin is isotropic (one k along the loaded axis), "
                             f"got k = {diag.tolist()}")
        phase = replace(twin.phases[0], k=scale * float(diag[0]))  # isotropic: the coupled model's phases are
        values = {key: scale * float(v) for key, v in moisture.items()}
        twin = replace(twin, phases=(phase,), moisture=replace(scene.moisture, phases={phase.name: values}))
    obs = simulate(assemble(twin), method=method)
    return Observables(np.asarray(obs.t, dtype=float), {f: np.asarray(v, dtype=float) for f, v in obs.mean_T.items()},
                       source=f"homogeneous twin of {scene.path or 'scene'}")


def moisture_twin(transport: npt.ArrayLike, state: MoistureState) -> tuple[float, dict[str, float]]:
    """The isotropic phase whose coupled flux matrix is ``transport`` (2 × 2, physical units, along the loaded axis:
    :func:`aromm.homogenization.moisture_cells.moisture_transport`), ``[[k + L_v δ_p a, L_v δ_p p], [δ_p a, D_φ +
    δ_p p]]`` inverted from its lower row and its (1, 1) entry: (k, {"D_phi": D_φ, "delta_p": δ_p}).  InputError
    when no phase has it (k ≤ 0 or a negative D_φ, δ_p beyond rounding).

    >>> state = MoistureState(20.0, 0.5)
    >>> f = np.array([[0.04 + state.latent_heat * 2e-11 * state.a, state.latent_heat * 2e-11 * state.p],
    ...               [2e-11 * state.a, 1e-9 + 2e-11 * state.p]])
    >>> k, values = moisture_twin(f, state)
    >>> round(k, 12), round(values["D_phi"] / 1e-9, 9), round(values["delta_p"] / 2e-11, 9)
    (0.04, 1.0, 1.0)
    """
    f = np.asarray(transport, dtype=float)
    delta = float(f[1, 0]) / state.a
    k = float(f[0, 0]) - state.latent_heat * delta * state.a
    d = float(f[1, 1]) - delta * state.p
    floor = 1e-9 * float(np.abs(f[1]).max())
    if k <= 0 or delta < -floor or d < -floor:
        raise InputError(f"moisture twin: the effective transport {f.tolist()} has no isotropic phase (k {k:g}, "
                         f"D_phi {d:g}, delta_p {delta:g})")
    return k, {"D_phi": max(d, 0.0), "delta_p": max(delta, 0.0)}
