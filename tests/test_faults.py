"""Fault injection (issue 10): bad inputs across every command refused with the right exit code, a message naming
the file, option or key and what is allowed, no traceback, and every input byte-identical afterwards.

The cases are in tests/fault_cases.py; ``python tests/test_faults.py --table`` runs them and prints the table
(command, exit code, first line of the message) from that same list.
"""

from __future__ import annotations

import json
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from fault_cases import Case, make_template, prepared, run
from fault_cases_lab import CASES

from aromm.cli import main
from aromm.core.observables import Observables, write_csv

REPO = Path(__file__).resolve().parent.parent
COMMANDS = {"simulate", "homogenize", "measure", "reduce", "identify", "bounds", "dem pack", "dem calibrate",
            "dem homogenize", "dem simulate"}


def command(case: Case) -> str:
    return " ".join(case.argv[:2]) if case.argv[0] == "dem" else case.argv[0]


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_template(tmp_path_factory.mktemp("template"))


def test_the_suite_covers_every_command_with_at_least_40_bad_inputs() -> None:
    assert len([c for c in CASES if c.code != 0]) >= 40
    assert {command(c) for c in CASES} >= COMMANDS
    assert len({c.id for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_fault(case: Case, template: Path, tmp_path: Path) -> None:
    outcome = run(case, prepared(template, tmp_path), tmp_path / "cache")
    assert outcome.code == case.code, outcome.err
    assert "Traceback" not in outcome.err + outcome.out
    missing = [name for name in case.names if name not in outcome.err]
    assert not missing, f"message lacks {missing}: {outcome.err}"
    assert all(s in outcome.out for s in case.stdout), outcome.out
    assert not outcome.changed, f"inputs changed: {outcome.changed}"
    if case.code == 2:
        assert not outcome.created, f"refused, yet wrote {outcome.created}"


@pytest.mark.parametrize("mistake", ["csv", "unknown"])
def test_refused_before_any_assembly_on_the_shipped_scene_with_an_empty_cache(
        mistake: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """A bad measurement file or unknown on data/scenes/wood_s1.toml (46³ voxels: a reduced-model build takes
    minutes) is refused without assembling anything, well within 10 s (measured: about 0.2 s wall)."""
    csv = tmp_path / "y.csv"
    t = np.arange(1.0, 61.0)
    write_csv(Observables(t, {"z0": t, "x1" if mistake == "csv" else "z1": t}), csv)
    unknown = "fibre.kk=0.05:1" if mistake == "unknown" else "fibre.k=0.05:1"
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "empty-cache"))

    def assembled(*args: object, **kwargs: object) -> None:
        raise AssertionError("the scene was assembled before the input was checked")
    monkeypatch.setattr("aromm.scene.scene_file.assemble", assembled)
    wall, cpu = time.perf_counter(), time.process_time()
    code = main(["identify", str(REPO / "data" / "scenes" / "wood_s1.toml"), "--measurements", str(csv),
                 "--unknown", unknown, "--unknown", "fibre.c=1e5:1e7"])
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    err = capsys.readouterr().err
    assert code == 2 and ("'x1'" in err if mistake == "csv" else "'fibre.kk'" in err), err
    assert wall < 10.0, f"refused after {wall:.1f} s wall ({cpu:.1f} s CPU, load {os.getloadavg()[0]:.1f})"
    assert not (tmp_path / "empty-cache").exists()


def test_our_own_outputs_are_replaced_without_force_and_get_the_umask_permissions(
        template: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Running a command twice replaces what it wrote (recognised as ours); the files are 0644 under umask 022."""
    work = prepared(template, tmp_path)
    monkeypatch.chdir(work)
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    old = os.umask(0o022)
    try:
        for _ in range(2):
            assert main(["simulate", "scene.toml", "--out", "res"]) == 0
            assert main(["measure", "scene.toml", "--homogeneous", "--out", "m.csv"]) == 0
            assert main(["identify", "scene.toml", "--measurements", "m.csv", "--model", "full", "--unknown",
                         "fibre.k=0.05:1", "--particles", "2", "--iterations", "1", "--plot", "fit.png",
                         "--checkpoint", "run.npz"]) == 0
            assert main(["dem", "pack", "--particles", "50", "--phi", "0.3", "--out", "p.npz", "--quiet"]) == 0
    finally:
        os.umask(old)
    for name in ("res/observables.csv", "res/field.vtu", "m.csv", "fit.png", "run.npz", "p.npz"):
        assert (work / name).stat().st_mode & 0o777 == 0o644, name
    assert main(["measure", "scene.toml", "--homogeneous", "--out", "scene.toml", "--force"]) == 2


def test_interrupted_identification_resumes_from_its_checkpoint(
        template: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """After Ctrl-C (exit 130, hint printed), the hinted command finishes the same run."""
    case = next(c for c in CASES if c.id == "identify-interrupted")
    work = prepared(template, tmp_path)
    assert run(case, work, tmp_path / "cache").code == 130
    monkeypatch.chdir(work)
    assert main([*case.argv, "--resume", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["estimates"]["fibre.k"] > 0


def table() -> str:
    """Markdown table of the cases as they run now (command, exit code, first line of the message)."""
    import tempfile

    rows = ["| case | command | exit | first line of the message |", "|---|---|---|---|"]
    wall = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        template = make_template(Path(tmp) / "template")
        for i, case in enumerate(CASES):
            root = Path(tmp) / f"case{i}"
            outcome = run(case, prepared(template, root), root / "cache")
            first = outcome.message.replace("|", "\\|") or "(result printed)"
            flag = "" if outcome.code == case.code else f" (expected {case.code})"
            rows.append(f"| {case.id} | {command(case)} | {outcome.code}{flag} | {first} |")
    cpu = sum(u.ru_utime + u.ru_stime for u in map(resource.getrusage, (resource.RUSAGE_SELF,
                                                                         resource.RUSAGE_CHILDREN)))
    rows.append(f"\n{len(CASES)} cases ({sum(c.subprocess for c in CASES)} in subprocesses): "
                f"{time.perf_counter() - wall:.1f} s wall, {cpu:.1f} s CPU (with the imports and subprocesses), "
                f"load average {os.getloadavg()[0]:.1f} on a shared machine")
    return "\n".join(rows)


if __name__ == "__main__":
    if "--table" not in sys.argv:
        sys.exit("usage: python tests/test_faults.py --table")
    print(table())
