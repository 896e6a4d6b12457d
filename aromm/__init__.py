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

from __future__ import annotations

from typing import TYPE_CHECKING

from aromm.core import lazy

#: Where each public name lives: imported on first use (PEP 562), so ``import aromm`` and ``aromm --version`` do not
#: load scipy, the solvers and every wing (``python -X importtime -c "import aromm"``; tests/test_startup.py).
_EXPORTS = {
    "homogenize": "aromm.api", "mean_capacity": "aromm.api", "reduce": "aromm.api", "simulate": "aromm.api",
    "InputError": "aromm.core.errors", "NumericalError": "aromm.core.errors",
    "Observables": "aromm.core.observables", "ThermalSystem": "aromm.core.system", "FullModel": "aromm.full.solve",
    "fluxmetric": "aromm.homogenization.properties", "homogeneous_twin": "aromm.homogenization.properties",
    "rev": "aromm.homogenization.representative",
    "homogeneous_measurements": "aromm.homogenization.synthetic", "ReducedModel": "aromm.reduction.rom",
    "Scene": "aromm.scene.scene_file", "assemble": "aromm.scene.scene_file", "load_scene": "aromm.scene.scene_file",
}

if TYPE_CHECKING:
    from aromm.api import homogenize, mean_capacity, reduce, simulate
    from aromm.core.errors import InputError, NumericalError
    from aromm.core.observables import Observables
    from aromm.core.system import ThermalSystem
    from aromm.full.solve import FullModel
    from aromm.homogenization.properties import fluxmetric, homogeneous_twin
    from aromm.homogenization.representative import rev
    from aromm.homogenization.synthetic import homogeneous_measurements
    from aromm.reduction.rom import ReducedModel
    from aromm.scene.scene_file import Scene, assemble, load_scene


__getattr__, __dir__ = lazy.exports(__name__, _EXPORTS)


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

