"""Recompute the stored outputs of the notebooks in notebooks/ at the papers' sizes (``AROMM_FULL=1``).

    python scripts/regenerate_notebooks.py                      # every notebook, one after the other
    python scripts/regenerate_notebooks.py table2 bounds        # only these (file stems)
    python scripts/regenerate_notebooks.py dem --small          # stop-gap: the tests' sizes, recorded as such
    nice -n 10 python scripts/regenerate_notebooks.py dem --cache ~/.cache/aromm

Each notebook is executed in a kernel with ``AROMM_FULL=1`` from the folder ``notebooks/``, with the
kernel's own inline matplotlib backend so that the figures are stored (``MPLBACKEND`` is removed from
the environment: a non-interactive backend such as Agg would leave the notebook without figures), and
written back in place (atomically, only when every cell ran without error), so the documentation
renders the stored outputs without executing anything.  The run is recorded in the notebook's metadata
under ``aromm``: ``full`` (true; false with ``--small``), the date, the wall seconds, the CPU seconds of
the kernel (a child process, counted once it has exited), the load average at start and end and the
number of cores (the machine may be shared: read the seconds with the load).  After a full run the table of
docs/reproductions.md is rewritten from the stored outputs (scripts/reproductions_table.py).  The tests
(tests/test_notebooks.py) execute the notebooks at small sizes in memory and never write them.

The reduced models are built in a fresh temporary cache unless ``--cache DIR`` is given, so the offline
seconds printed in the outputs are measured, not read from an earlier run.
"""

from __future__ import annotations

import argparse
import datetime
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"


def regenerate(path: Path, cache: Path, timeout: int | None = None, full: bool = True) -> float:
    """Execute the notebook at ``path`` with ``AROMM_FULL=1`` (``full``; else at the tests' small sizes) and
    store it with its outputs; returns the wall seconds."""
    nb = nbformat.read(path, as_version=4)
    env = {k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "AROMM_FULL")}
    env["AROMM_CACHE_DIR"] = str(cache)
    if full:
        env["AROMM_FULL"] = "1"
    load_start = os.getloadavg()
    cpu_start = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    NotebookClient(nb, timeout=timeout, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute(env=env)
    wall = time.perf_counter() - start
    cpu_end = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (cpu_end.ru_utime + cpu_end.ru_stime) - (cpu_start.ru_utime + cpu_start.ru_stime)
    nb.metadata["aromm"] = {
        "full": full,
        "date": datetime.date.today().isoformat(),
        "wall_seconds": round(wall, 1),
        "kernel_cpu_seconds": round(cpu, 1),
        "loadavg_start": [round(x, 2) for x in load_start],
        "loadavg_end": [round(x, 2) for x in os.getloadavg()],
        "cpus": os.cpu_count(),
        "command": f"python scripts/regenerate_notebooks.py {path.stem}" + ("" if full else " --small"),
    }
    tmp = path.with_suffix(".ipynb.tmp")
    nbformat.write(nb, tmp)
    tmp.replace(path)
    return wall


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="notebook stems (default: every notebook in notebooks/)")
    parser.add_argument("--cache", type=Path, help="reduced-model cache (default: a fresh temporary folder)")
    parser.add_argument("--timeout", type=int, default=None, help="seconds per cell (default: none)")
    parser.add_argument("--small", action="store_true",
                        help="store outputs at the tests' small sizes instead (a stop-gap: the metadata says so)")
    args = parser.parse_args(argv)
    paths = [NOTEBOOKS / f"{n}.ipynb" for n in args.names] or sorted(NOTEBOOKS.glob("*.ipynb"))
    missing = [p.name for p in paths if not p.is_file()]
    if missing:
        parser.error(f"no such notebook in notebooks/: {', '.join(missing)}")
    for path in paths:
        with tempfile.TemporaryDirectory(prefix="aromm-nb-") as tmp:
            cache = args.cache or Path(tmp)
            size = "small sizes" if args.small else "AROMM_FULL=1"
            print(f"{path.name}: running at {size} (load {os.getloadavg()[0]:.1f}) ...", flush=True)
            wall = regenerate(path, cache, args.timeout, full=not args.small)
            print(f"{path.name}: stored, {wall:.0f} s wall (load {os.getloadavg()[0]:.1f})", flush=True)
    if not args.small:  # the table of docs/reproductions.md quotes the stored outputs
        subprocess.run([sys.executable, str(ROOT / "scripts" / "reproductions_table.py")], check=True)
        print("docs/reproductions.md: table rewritten from the stored outputs", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
