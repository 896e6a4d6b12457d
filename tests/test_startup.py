"""Start-up cost of the command line (issue 37, item 4): ``aromm --version`` loads none of the numerical wings.

Truth: the modules a fresh interpreter has loaded after the command (``sys.modules``), not a timing, which would
depend on the machine; the CPU seconds are printed for the record.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

HEAVY = ("scipy", "matplotlib", "skfem", "pyamg", "aromm.api", "aromm.scene", "inverse")
PROBE = """
import json, resource, sys
from aromm.cli import main
try:
    code = main(sys.argv[1:])
except SystemExit as done:
    code = done.code
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"code": code, "modules": sorted(sys.modules), "cpu": usage.ru_utime + usage.ru_stime}),
      file=sys.__stderr__)
"""


def loaded(*argv: str) -> dict[str, object]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    run = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, env=env, check=False)
    result: dict[str, object] = json.loads(run.stderr.strip().splitlines()[-1])
    print(argv, f"{result['cpu']:.2f} CPU s")
    return result


@pytest.mark.parametrize("argv", [("--version",), ("nosuchcommand",)])
def test_the_group_alone_loads_no_wing(argv: tuple[str, ...]) -> None:
    """``--help`` lists every command's summary, so it imports the command modules; these two need none."""
    result = loaded(*argv)
    assert result["code"] in (0, 2)
    heavy = [m for m in result["modules"] if m.startswith(HEAVY)]  # type: ignore[attr-defined]
    assert heavy == [], heavy
