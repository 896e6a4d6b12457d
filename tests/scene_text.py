"""Scene text shared by the tests: [Chavez2020] scenario 1 on a fibre (label 1) / gas (label 0) image, a mesh
cell, a homogeneous slab between fixed temperatures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aromm.studies.chavez2020 import scenario_1_text

SLAB_L, SLAB_K, SLAB_C = 0.1, 33.0, 7.02e6  # [Hassan2019]'s steel slab: 0.1 m, 33 W/(m K), rho c (J/(m3 K))
SLAB_ALPHA = SLAB_K / SLAB_C
SLAB_TAU = SLAB_L**2 / SLAB_ALPHA


def scenario_1(image: str, voxel_size: str, end: str, dt: str) -> str:
    """Flux 500 W/m² on z0, h = 20 W/(m² K) to 0 °C on z1, T0 = 0; values given as TOML literals."""
    return scenario_1_text(f'image = "{image}"\nvoxel_size = {voxel_size}', end=end, dt=dt)


#: A filler octant in a matrix cell (``aromm.bounds.cell_mesh`` written to cell.vtu), contact resistance R.
MESH_CELL = """
[geometry]
mesh = "cell.vtu"

[phases.filler]
label = 1
k = 2.0
c = 3.0e6

[phases.matrix]
label = 2
k = 1.0
c = 1.0e6

[interfaces."filler|matrix"]
R = {R}
"""


def steel_slab(folder: Path, nz: int, end: float, dt: float, sensors: str = "") -> Path:
    """A scene file (and its 2 × 3 × nz image) of the slab: z0 at 25 °C, z1 at 100 °C, T0 = 25 °C [Hassan2019]."""
    np.save(folder / f"slab{nz}.npy", np.zeros((2, 3, nz), dtype=np.int32))
    text = f"""
[geometry]
image = "slab{nz}.npy"
voxel_size = [{SLAB_L / 2}, {SLAB_L / 3}, {SLAB_L / nz}]
[phases.steel]
label = 0
k = {SLAB_K}
c = {SLAB_C}
[boundary.z0]
T = 25.0
[boundary.z1]
T = 100.0
[initial]
T = 25.0
[time]
end = {end}
dt = {dt}
[outputs]
mean_T = ["z0", "z1"]
{sensors}
"""
    path = folder / f"slab{nz}.toml"
    path.write_text(text, encoding="utf-8")
    return path
