"""Peak memory of ``aromm simulate --out`` (the final field exported) against the previous path.

Each path runs in its own Python process (peak resident memory = that process's ru_maxrss):

* ``every step kept`` (previous path): ``transient(fields=True)`` keeps the field of every output time,
  then the last one is written as VTU;
* ``final field only`` (this path): ``aromm simulate SCENE --out DIR`` keeps only the final field
  (``fields="last"``, interpolated as the steps pass);
* ``no --out``: ``aromm simulate SCENE``, face means only (the floor: assembly and factorisations).

Default scene: the shipped wood VER coarsened 2× (23³ voxels, scenario 1); ``--scene FILE`` for any
scene, e.g. ``--scene data/scenes/wood_s1.toml`` (46³, the issue's case, ~4 min per path on 2 cores).

Usage: python benchmarks/simulate_memory.py [--scene FILE] [--skip-previous]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

PREVIOUS = """
import resource, sys
from pathlib import Path
from aromm.core.series import write_vtu
from aromm.scene.scene_file import assemble, load_scene
from aromm.full.solve import simulate
system = assemble(load_scene(sys.argv[1]))
obs = simulate(system, fields=True)
write_vtu(Path(sys.argv[2]) / "field.vtu", system.geometry, obs.fields[-1])
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, system.n)
"""

CLI = """
import resource, sys
from aromm.cli import main
code = main(["simulate", *sys.argv[1:]])
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, code, file=sys.stderr)
"""


def coarse_scene(folder: Path) -> Path:
    """The shipped VER (46³) coarsened 2× by taking every other voxel, under scenario 1 (wood_s1.toml)."""
    image = np.load(ROOT / "data" / "wood_ver.npz")["labels"][::2, ::2, ::2]
    np.save(folder / "ver23.npy", image)
    text = (ROOT / "data" / "scenes" / "wood_s1.toml").read_text(encoding="utf-8")
    text = text.replace('image = "../wood_ver.npz"', 'image = "ver23.npy"').replace("voxel_size = 5.0e-6",
                                                                                 "voxel_size = 1.0e-5")
    path = folder / "wood_s1_coarse.toml"
    path.write_text(text, encoding="utf-8")
    return path


def run(code: str, args: list[str]) -> tuple[float, float, float, str]:
    """(peak bytes, wall s, CPU s of the child, its output) for one path in a fresh interpreter."""
    wall = time.perf_counter()
    before = os.times()
    proc = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, check=True,
                          cwd=ROOT)
    after = os.times()
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    line = (proc.stdout.strip().splitlines() or [""])[-1] if code is PREVIOUS else proc.stderr.strip().splitlines()[-1]
    return float(line.split()[0]), time.perf_counter() - wall, cpu, line


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=None)
    parser.add_argument("--skip-previous", action="store_true", help="do not run the every-step path")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scene = args.scene.resolve() if args.scene else coarse_scene(folder)
        from aromm.scene.scene_file import load_scene

        sc = load_scene(scene)
        nodes = int(np.prod(np.asarray(sc.geometry.labels.shape) + 1))
        steps = len(sc.time.times) if sc.time is not None else 0
        print(f"scene {scene.name}: {sc.geometry.labels.shape} voxels, {nodes} nodes, {steps} steps; "
              f"one field = {nodes * 8 / 1e6:.1f} MB, every step = {(steps + 1) * nodes * 8 / 1e9:.2f} GB")
        rows = []
        if not args.skip_previous:
            rows.append(("every step kept (previous)", run(PREVIOUS, [str(scene), str(folder / "prev")])))
        rows.append(("final field only (--out)", run(CLI, [str(scene), "--out", str(folder / "new")])))
        rows.append(("no --out", run(CLI, [str(scene)])))
        print(f"{'path':<28}{'peak GB':>9}{'B/voxel':>9}{'wall s':>8}{'CPU s':>8}")
        for name, (peak, wall, cpu, _) in rows:
            print(f"{name:<28}{peak / 1e9:9.3f}{peak / sc.geometry.labels.size:9.0f}{wall:8.1f}{cpu:8.1f}")
        if len(rows) == 3:
            print(f"ratio previous / this path: {rows[0][1][0] / rows[1][1][0]:.2f}; "
                  f"this path / no --out: {rows[1][1][0] / rows[2][1][0]:.2f}")
    print(f"load average {os.getloadavg()[0]:.2f} (shared machine: wall times inflate, CPU seconds less so)")


if __name__ == "__main__":
    main()
