"""aromm: thermal properties of the phases of heterogeneous materials.

Public API::

    scene = aromm.load_scene("data/scenes/wood_s1.toml")
    system = aromm.assemble(scene)                  # ThermalSystem
    obs = aromm.simulate(system, scene.parameters)  # full model -> Observables
    k_eff = aromm.homogenize(scene)                 # 3x3 tensor, W/(m K)
    k_s1 = aromm.fluxmetric(scene).k                # [Chavez2020, eq. 13] under the scene's own faces
    rom = aromm.reduce(system, order=200)           # AROMM ReducedModel (cached bases)
    study = aromm.rev(scene)                        # REV study: k̄ spread against sub-volume edge, crop
"""

from aromm.core.errors import InputError, NumericalError
from aromm.core.observables import Observables
from aromm.core.system import ThermalSystem
from aromm.full.solve import FullModel
from aromm.homogenization.properties import fluxmetric, homogeneous_twin
from aromm.homogenization.representative import rev
from aromm.homogenization.synthetic import homogeneous_measurements
from aromm.reduction.rom import ReducedModel
from aromm.scene.scene_file import Scene, assemble, load_scene

__all__ = [
    "FullModel",
    "InputError",
    "NumericalError",
    "Observables",
    "ReducedModel",
    "Scene",
    "ThermalSystem",
    "assemble",
    "fluxmetric",
    "homogeneous_measurements",
    "homogeneous_twin",
    "homogenize",
    "load_scene",
    "mean_capacity",
    "reduce",
    "rev",
    "simulate",
]
__version__ = "0.1.0"
