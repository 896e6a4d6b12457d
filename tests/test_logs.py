"""Progress in the log when stderr is not a terminal (issue 23 item 5): a line per stage of a build and per 10 % of
an eigen-solve's pairs, each with the elapsed time; on a terminal only warnings and the CSV reader's notes."""

from __future__ import annotations

import contextlib
import io
import logging
import re
from pathlib import Path

import pytest
from fault_cases import make_template

from aromm.cli import main
from aromm.linalg.eigensolvers import EigenProgress, PairsBar


def test_a_redirected_build_logs_every_stage_with_its_elapsed_time(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    work = make_template(tmp_path / "case")
    monkeypatch.chdir(work)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        assert main(["reduce", "scene.toml", "--order", "8", "--cache-dir", str(tmp_path / "cache")]) == 0
    lines = err.getvalue().splitlines()
    stamped = [ln for ln in lines if re.match(r"aromm: \[\s*\d+\.\d s\] ", ln)]
    for stage in ("reduce: modes", "Steklov modes: ", "Dirichlet modes: ", "reduce: projection",
                  "reduce: aromm to order 8", "reduced model built"):
        assert any(stage in ln for ln in stamped), (stage, lines)
    seconds = [float(re.search(r"\[\s*([\d.]+) s\]", ln)[1]) for ln in stamped]  # type: ignore[index]
    assert seconds == sorted(seconds)
    assert not logging.getLogger("aromm").handlers  # the command's handler is gone afterwards


def test_eigen_progress_is_logged_per_tenth_of_the_pairs(caplog: pytest.LogCaptureFixture) -> None:
    bar = PairsBar(enabled=False)
    with caplog.at_level(logging.INFO, logger="aromm.linalg.eigensolvers"):
        for converged in range(41):
            bar(EigenProgress("Dirichlet modes", converged, 40, converged, 1e-3))
    bar.close()
    assert len(caplog.records) == 11  # 0, 4, 8, ..., 40 of 40
