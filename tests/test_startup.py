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
    """Neither needs a command module."""
    result = loaded(*argv)
    assert result["code"] in (0, 2)
    heavy = [m for m in result["modules"] if m.startswith(HEAVY)]  # type: ignore[attr-defined]
    assert heavy == [], heavy


#: What a command's options may not load: the solvers and every numerical wing (the light modules of aromm.scene and
#: inverse that hold the choices and defaults are allowed).
WINGS = ("scipy", "matplotlib", "skfem", "pyamg", "aromm.api", "aromm.scene.scene_file", "aromm.reduction", "aromm.fem",
         "aromm.fv", "aromm.homogenization", "aromm.dem", "aromm.bounds", "aromm.full", "inverse.identification",
         "inverse.optimisers")
COMMANDS = [("identify",), ("simulate",), ("homogenize",), ("measure",), ("reduce",), ("rev",), ("segment",),
            ("bounds",), ("dem", "pack"), ("dem", "simulate")]


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_a_refused_option_loads_no_wing(command: tuple[str, ...]) -> None:
    """A typo in an option is refused by click while it parses, before the command runs: the command's module is
    imported for its options, and those come from light modules (aromm.core.choices, inverse.defaults), so the
    refusal costs about 0.3 CPU s instead of 2–3 (issue 37, item 4: at most 1)."""
    result = loaded(*command, "--no-such-option")
    assert result["code"] == 2
    heavy = [m for m in result["modules"] if m.startswith(WINGS)]  # type: ignore[attr-defined]
    assert heavy == [], heavy


def test_help_lists_every_command_without_the_wings() -> None:
    result = loaded("--help")
    assert result["code"] == 0
    heavy = [m for m in result["modules"] if m.startswith(WINGS)]  # type: ignore[attr-defined]
    assert heavy == [], heavy


#: What a warm identification on a voxel scene does not need (issue 37, item 4): scipy.stats (the residual tests and
#: the intervals use scipy.special), scikit-fem (mesh scenes), scipy.ndimage (cutting an insulating phase's isolated
#: voxels), matplotlib (--plot).
NOT_FOR_IDENTIFY = ("scipy.stats", "skfem", "scipy.ndimage", "matplotlib")
IDENTIFY_PATH = ("aromm.cli.identify", "aromm.cli.identify_report", "aromm.api", "aromm.scene.scene_file",
                 "inverse.identification", "inverse.uncertainty", "inverse.residuals", "aromm.reduction.rom")


def test_the_identify_path_imports_only_what_it_uses() -> None:
    probe = f"import importlib, json, sys\nfor m in {IDENTIFY_PATH!r}: importlib.import_module(m)\n" \
            "print(json.dumps(sorted(sys.modules)))"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True)
    extra = [m for m in json.loads(run.stdout) if m.startswith(NOT_FOR_IDENTIFY)]
    assert extra == [], extra
