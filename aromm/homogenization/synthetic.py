"""Synthetic measurements from the homogeneous orthotropic twin of a scene [Chavez2020, eq. 1, § 4.2].

The paper's measurements come from the *homogeneous orthotropic* twin of the sample: one phase of conductivity
diag(k̄_xx, k̄_yy, k̄_zz) (eq. 13) and capacity c̄ (eq. 14) on the same box under the same scenario.  The result is
the toolkit's one time-series table (:class:`aromm.core.observables.Observables`), which :mod:`inverse` reads as
measurements.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.observables import Observables
from aromm.full.solve import simulate
from aromm.homogenization.properties import homogeneous_twin
from aromm.scene.scene_file import Scene, assemble


def homogeneous_measurements(scene: Scene, k: npt.ArrayLike, c: float, *, perturbation: float = 0.0,
                             method: str = "auto") -> Observables:
    """Face means of the homogeneous orthotropic twin of ``scene`` [Chavez2020, eq. 1, § 4.2].

    ``k`` is the effective conductivity (W/(m K)): a 3x3 tensor (``aromm.homogenize``) or, for a
    scenario loaded along one axis, the scalar ``aromm.fluxmetric(scene).k`` ([Chavez2020]
    § 4.2; the unloaded axes carry no heat); ``c`` the mean capacity (J/(m^3 K);
    ``aromm.mean_capacity(scene)``, eq. 14).  Every homogeneous property is multiplied by
    ``1 + perturbation`` (§ 4.3 studies +2 %: 0.02).  The twin (``aromm.homogeneous_twin``) has the
    scene's box, face conditions, time grid and outputs; it is simulated by the full model
    with the linear solver ``method``.
    """
    if scene.time is None:
        raise InputError(f"{scene.where}measurements need a transient scene ([time] with end and dt)")
    if not (math.isfinite(perturbation) and perturbation > -1):
        raise InputError(f"perturbation must be a finite fraction > -1, got {perturbation!r}")
    scale = 1.0 + perturbation
    twin = homogeneous_twin(scene, scale * np.asarray(k, dtype=float), scale * float(c))
    obs = simulate(assemble(twin), method=method)
    return Observables(np.asarray(obs.t, dtype=float), {f: np.asarray(v, dtype=float) for f, v in obs.mean_T.items()},
                       source=f"homogeneous twin of {scene.path or 'scene'}")
