"""Scene text shared by the tests: [Chavez2020] scenario 1 on a fibre (label 1) / gas (label 0) image."""

from __future__ import annotations


def scenario_1(image: str, voxel_size: str, end: str, dt: str) -> str:
    """Flux 500 W/m² on z0, h = 20 W/(m² K) to 0 °C on z1, T0 = 0; values given as TOML literals."""
    return f"""
[geometry]
image = "{image}"
voxel_size = {voxel_size}

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


#: A filler octant in a matrix cell (``aromm.effective.cell_mesh`` written to cell.vtu), contact resistance R.
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
