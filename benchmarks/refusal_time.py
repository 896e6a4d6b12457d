"""How long ``aromm identify`` takes to refuse a bad input on the shipped wood scene with an empty cache.

Issue 10 item 2: a measurement CSV naming a face the scene does not observe, or an unknown parameter, must be
refused in seconds, before the reduced model is built (minutes on 2 cores).  Each case runs in a fresh
interpreter (imports included) with ``AROMM_CACHE_DIR`` an empty folder; printed: exit code, wall and CPU
seconds of the child, its peak resident memory, the load average (the machine is shared), and the message.

``--previous DIR`` runs the same cases on another checkout (e.g. ``git archive <commit> | tar -x -C DIR``)
put first on ``PYTHONPATH``, for the before/after comparison; ``--timeout`` bounds each of its runs.

Usage: python benchmarks/refusal_time.py [--previous DIR] [--timeout 1800]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data" / "scenes" / "wood_s1.toml"
CASES = {
    "CSV face x1 (not observed)": ("bad.csv", "fibre.k=0.05:1"),
    "unknown fibre.kk": ("good.csv", "fibre.kk=0.05:1"),
}


def write_csvs(folder: Path) -> None:
    t = np.arange(1.0, 61.0)
    for name, faces in (("bad.csv", ("z0", "x1")), ("good.csv", ("z0", "z1"))):
        rows = "\n".join(",".join(repr(float(v)) for v in (ti, 0.1 * ti, 0.05 * ti)) for ti in t)
        (folder / name).write_text(f"t,{','.join(faces)}\n{rows}\n", encoding="utf-8")


def run(folder: Path, csv: str, unknown: str, code_path: Path | None, timeout: float) -> tuple[str, ...]:
    cache = Path(tempfile.mkdtemp(dir=folder, prefix="cache-"))
    env = {**os.environ, "AROMM_CACHE_DIR": str(cache)}
    if code_path is not None:
        env["PYTHONPATH"] = f"{code_path}{os.pathsep}{env.get('PYTHONPATH', '')}"
    argv = [sys.executable, "-c", "import sys; from aromm.cli import main; sys.exit(main())", "identify",
            str(SCENE), "--measurements", str(folder / csv), "--unknown", unknown, "--unknown", "fibre.c=1e5:1e7"]
    before, wall = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    try:
        proc = subprocess.run(argv, check=False, capture_output=True, text=True, env=env, timeout=timeout, cwd=folder)
        code, message = str(proc.returncode), (proc.stderr.strip().splitlines() or [""])[-1][:90]
    except subprocess.TimeoutExpired:
        code, message = "-", f"still running after {timeout:g} s (killed)"
    after, wall = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter() - wall
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return code, f"{wall:.1f}", f"{cpu:.1f}", f"{after.ru_maxrss / 1e6:.2f}", f"{os.getloadavg()[0]:.1f}", message


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--previous", type=Path, default=None, help="another checkout to compare with")
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds allowed per previous run")
    args = parser.parse_args()
    paths: list[tuple[str, Path | None]] = [("this checkout", None)]
    if args.previous is not None:
        paths.append((f"previous ({args.previous})", args.previous.resolve()))
    print(f"{'path':<24}{'case':<30}{'exit':>5}{'wall s':>8}{'CPU s':>8}{'peak GB*':>9}{'load':>6}  message")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_csvs(folder)
        for label, code_path in paths:
            for case, (csv, unknown) in CASES.items():
                code, wall, cpu, peak, load, message = run(folder, csv, unknown, code_path, args.timeout)
                print(f"{label:<24}{case:<30}{code:>5}{wall:>8}{cpu:>8}{peak:>9}{load:>6}  {message}")
    print("* largest peak resident memory of the children so far (ru_maxrss); the machine is shared (2 cores)")


if __name__ == "__main__":
    main()
