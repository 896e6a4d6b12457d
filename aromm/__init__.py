"""aromm: thermal properties of the phases of heterogeneous materials.

Public API (DESIGN.md)::

    scene = aromm.load_scene("scenes/wood_z.toml")
    system = aromm.assemble(scene)
    obs = aromm.simulate(system, scene.parameters)
    k_eff = aromm.homogenize(scene)
"""

from aromm.errors import InputError, NumericalError
from aromm.system import Observables, ThermalSystem

__all__ = ["InputError", "NumericalError", "Observables", "ThermalSystem"]
__version__ = "0.1.0"
