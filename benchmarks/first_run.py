"""How long the first ``aromm reduce`` of a scene takes with an empty cache (the figure the README quotes).

Issue 23 item 5: the README's first-run time must come from a script in the repository, with the machine and
its load.  The build runs in a fresh interpreter with an empty cache folder; printed on one line: wall and CPU
seconds of the child (user + system, all its threads), its peak resident memory, the load average before and
after (the machine may be shared), the cores and CPU model, and then the build's own log (stages with their
elapsed times, aromm.cli.logs).  ``--refine`` and ``--order`` are passed on.

Usage: python benchmarks/first_run.py [--scene data/scenes/wood_s1.toml] [--order 200] [--refine 1]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=ROOT / "data" / "scenes" / "wood_s1.toml")
    parser.add_argument("--order", type=int, default=200)
    parser.add_argument("--refine", type=int, default=1)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        load_before = os.getloadavg()
        wall = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", "import sys; from aromm.cli import main; sys.exit(main())",
                               "reduce", str(args.scene), "--order", str(args.order), "--refine", str(args.refine),
                               "--cache-dir", cache, "--json"], capture_output=True, text=True, check=False)
        wall = time.perf_counter() - wall
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"aromm reduce failed ({proc.returncode}): {proc.stderr}")
    info = json.loads(proc.stdout)
    print(f"first aromm reduce of {args.scene.name} (order {info['order']}, Ñ = {info['modes']}, refine "
          f"{args.refine}): {wall:.1f} s wall, {usage.ru_utime + usage.ru_stime:.1f} s CPU, peak "
          f"{usage.ru_maxrss / 2**20:.2f} GB; load average {load_before[0]:.1f} before, {os.getloadavg()[0]:.1f} "
          f"after; {os.cpu_count()} cores, {cpu_model()}; {time.strftime('%Y-%m-%d')}")
    print(proc.stderr, end="")


if __name__ == "__main__":
    main()
