"""How long the README's main job takes on a fresh machine: the first ``aromm identify`` of the shipped scene, with an
empty cache (it builds the reduced model), and what that model is (the figures the README and the docs quote).

Issue 23 item 5 and issue 38 item 5: the first-run figures of the docs come from this script's record, not prose.
The measurements are made by ``aromm measure`` (not counted); the identification then runs in a fresh interpreter
with an empty cache folder, as the README writes it.  Printed on one line: wall and CPU seconds of the child (user
+ system, all its threads), its peak resident memory, the model (method, order, estimated error), the load average
before and after (the machine may be shared), the cores and CPU model; then the build's own log (aromm.cli.logs).
``--record FILE`` also writes them as JSON (benchmarks/records/first_run.json, which tests/test_docs_pages.py holds
the README, getting_started.md and guide/cache.md to).

Usage: python benchmarks/first_run.py [--scene data/scenes/wood_s1.toml] [--record benchmarks/records/first_run.json]
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


#: The README's main job: ``aromm identify`` with these unknowns (README, command 1).
UNKNOWNS = ("--unknown", "fibre.k=0.05:1", "--unknown", "fibre.c=1e5:1e7")


def aromm(*argv: str, cache: str) -> subprocess.CompletedProcess[str]:
    """``aromm argv`` in a fresh interpreter whose cache is the folder ``cache``."""
    return subprocess.run([sys.executable, "-c", "import sys; from aromm.cli import main; sys.exit(main())", *argv],
                          capture_output=True, text=True, check=False, env={**os.environ, "AROMM_CACHE_DIR": cache})


def commit() -> str:
    run = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                         check=False)
    return run.stdout.strip() or "unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=ROOT / "data" / "scenes" / "wood_s1.toml")
    parser.add_argument("--record", type=Path, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        data = Path(folder) / "s1.csv"
        cache = str(Path(folder) / "cache")
        made = aromm("measure", str(args.scene), "--homogeneous", "--out", str(data), cache=cache)
        if made.returncode != 0:
            sys.exit(f"aromm measure failed ({made.returncode}): {made.stderr}")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        load_before = os.getloadavg()
        wall = time.perf_counter()
        proc = aromm("identify", str(args.scene), "--measurements", str(data), *UNKNOWNS, "--json", cache=cache)
        wall = time.perf_counter() - wall
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"aromm identify failed ({proc.returncode}): {proc.stderr}")
    model = json.loads(proc.stdout)["model"]
    cpu = usage.ru_utime + usage.ru_stime - before.ru_utime - before.ru_stime
    record = {"scene": args.scene.name, "command": "identify " + " ".join(UNKNOWNS), "method": model["method"],
              "order": model["order"], "reference_error": model["reference_error"], "wall_seconds": round(wall, 1),
              "cpu_seconds": round(cpu, 1), "peak_gb": round(usage.ru_maxrss / 2**20, 2),
              "load_before": round(load_before[0], 2), "load_after": round(os.getloadavg()[0], 2),
              "cores": os.cpu_count(), "cpu": cpu_model(), "date": time.strftime("%Y-%m-%d"), "commit": commit()}
    print(f"first aromm identify of {args.scene.name} ({record['method']} model of order {record['order']}, "
          f"estimated error {record['reference_error']:.2g} °C): {wall:.1f} s wall, {cpu:.1f} s CPU, peak "
          f"{record['peak_gb']:.2f} GB; load average {load_before[0]:.1f} before, {record['load_after']:.1f} after; "
          f"{record['cores']} cores, {record['cpu']}; {record['date']}")
    print(proc.stderr, end="")
    if args.record is not None:
        args.record.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
