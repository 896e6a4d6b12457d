"""Small models shared by the tests of the ``inverse`` package (not a test module itself)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aromm.core.observables import Observables
from aromm.core.system import FloatArray, ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import FullModel

TRUTH = {"fibre.k": 0.3, "fibre.c": 4.0e6}
PHASES = (PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4.0e6))
BOX = 231e-6  # m, the VER of [Chavez2020]


def twin_case(folder: Path, dt: str = "1.0") -> tuple[Path, Path]:
    """A 4³ scene (scenario 1 on :func:`tracheids`, 20 s in steps of ``dt``) and noise-free measurements made by
    its own full model at the truth, written in ``folder``: (scene file, CSV)."""
    from scene_text import scenario_1

    from aromm.scene.scene_file import assemble, load_scene
    from inverse.measurements import save_measurements, simulate_measurements

    np.save(folder / "labels.npy", tracheids(4))
    scene = folder / "scene.toml"
    scene.write_text(scenario_1("labels.npy", repr(BOX / 4), "20.0", dt), encoding="utf-8")
    csv = folder / "y.csv"
    save_measurements(simulate_measurements(FullModel(assemble(load_scene(scene))), TRUTH), csv)
    return scene, csv


def tracheids(n: int) -> np.ndarray:
    """A deterministic two-phase image: fibre walls on planes i % 3 == 0 and j % 3 == 0 (tubes along z)."""
    i, j, _ = np.meshgrid(range(n), range(n), range(n), indexing="ij")
    return ((i % 3 == 0) | (j % 3 == 0)).astype(np.int32)


def scenario_system(axis: str = "z", n: int = 6, end: float = 40.0, dt: float = 1.0,
                    steady: bool = False) -> ThermalSystem:
    """[Chavez2020, Table 1] on a small image: 500 W/m² into face <axis>0, h = 20 W/(m² K) on <axis>1."""
    return assemble_voxels(tracheids(n), (BOX / n,) * 3, PHASES,
                           [FaceSpec(f"{axis}0", flux=500.0), FaceSpec(f"{axis}1", h=20.0)],
                           time=None if steady else TimeGrid(end, dt), outputs=[f"{axis}0", f"{axis}1"])


def scenario_model(axis: str = "z", n: int = 6, end: float = 40.0, dt: float = 1.0) -> FullModel:
    return FullModel(scenario_system(axis, n, end, dt))


class LinearModel:
    """Ŷ(t_i) = Σ_j A_ij θ_j on one output "a": a forward model linear in its parameters."""

    def __init__(self, design: FloatArray, names: tuple[str, ...]) -> None:
        self.design = np.asarray(design, dtype=float)
        self.names = names

    @property
    def outputs(self) -> tuple[str, ...]:
        return ("a",)

    @property
    def parameter_names(self) -> frozenset[str]:
        return frozenset(self.names)

    @property
    def default_times(self) -> FloatArray:
        return np.arange(1.0, self.design.shape[0] + 1.0)

    def simulate(self, params: Mapping[str, float] | None = None, times: npt.ArrayLike | None = None) -> Observables:
        y = self.simulate_batch({k: [v] for k, v in (params or {}).items()}, times)[0]
        return Observables(t=self.default_times, mean_T={"a": y[:, 0]})

    def simulate_batch(self, params: Mapping[str, npt.ArrayLike], times: npt.ArrayLike | None = None) -> FloatArray:
        theta = np.column_stack([np.atleast_1d(np.asarray(params[n], dtype=float)) for n in self.names])
        return (theta @ self.design.T)[:, :, None]
