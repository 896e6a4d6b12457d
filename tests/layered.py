"""A layered body loaded along z and its independent 1-D reference (shared by the tests, not a test module).

12 layers of 20 µm normal to z, two phases; a flux pulse on z0, convection on z1 to a ramped T_ext.  Time
scales: diffusion across ~0.8 s, mean temperature c̄ L / h ~ 40 s.  The 1-D reference (tests/slab1d.py) is
exact in time on the same z nodes, so the voxel model differs from it by its time stepping (full model)
or its reduction (reduced model) only.
"""

from __future__ import annotations

import numpy as np
from slab1d import Slab, solve

from aromm.core.profiles import Profile
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels

LAYERS = np.array([1, 1, 0, 0, 1, 0, 1, 1, 0, 1, 0, 0])
DZ = 2e-5
PROPS = {1: (0.3, 4.0e6), 0: (0.1, 1.5e6)}
PHASES = (PhaseSpec("matrix", 0, *PROPS[0]), PhaseSpec("fibre", 1, *PROPS[1]))
PULSE = Profile((0.0, 0.5, 3.0, 3.5), (0.0, 500.0, 500.0, 0.0))
RAMP = Profile((0.0, 10.0), (0.0, 2.0))
BREAKS = (0.5, 3.0, 3.5, 10.0)
TIMES = np.round(0.1 * np.arange(1, 201), 12)
H = 20.0
T0 = 1.0


def layered_system(dt: float = 0.1, **faces: FaceSpec) -> ThermalSystem:
    labels = np.broadcast_to(LAYERS, (2, 2, LAYERS.size)).copy()
    boundary = [faces.get("z0", FaceSpec("z0", flux=PULSE)), faces.get("z1", FaceSpec("z1", h=H, T_ext=RAMP))]
    return assemble_voxels(labels, (1e-5, 1e-5, DZ), PHASES, boundary, time=TimeGrid(20.0, dt), initial_T=T0,
                           outputs=["z0", "z1"])


def layered_reference(values: dict[str, float] | None = None, times: np.ndarray = TIMES) -> np.ndarray:
    """Face means z0, z1 of the 1-D FE on the same nodes, exact in time (matrix exponentials)."""
    v = {"fibre.k": PROPS[1][0], "fibre.c": PROPS[1][1], "z1.h": H, **(values or {})}
    k = np.where(LAYERS == 1, v["fibre.k"], PROPS[0][0])
    c = np.where(LAYERS == 1, v["fibre.c"], PROPS[0][1])
    out = solve(Slab(k, c, DZ), times, flux=lambda t: float(PULSE(t)), h=v["z1.h"], t_ext=lambda t: float(RAMP(t)),
                initial=T0, breaks=BREAKS)
    return out[:, [0, -1]]
