"""One build per model at a time, and an entry of another kind rebuilt (issue 23 item 6).

Truths: the order of events between two real processes (the second waits for the first's lock, then reads the
entry it wrote: one build), the folder's content afterwards (entries only: no lock, no temporary file), and the
warning on a valid .npz of another kind at a key.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from fault_cases import make_template

from aromm.cli import main
from aromm.core.cache import KINDS, CacheWarning, NpzCache

HOLD = """
import sys, time
from aromm.core.cache import NpzCache
with NpzCache(sys.argv[1]).lock("rom", "k"):
    print("locked", flush=True)
    time.sleep(float(sys.argv[2]))
    NpzCache(sys.argv[1]).save("rom", "k", {"capacity.names": [1], "conductance.names": [2]})
"""


def test_a_second_holder_waits_then_finds_the_entry_and_no_lock_file_is_left(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    first = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path), "1.0"], stdout=subprocess.PIPE, env=env)
    assert first.stdout is not None and first.stdout.readline().strip() == b"locked"
    cache = NpzCache(tmp_path)
    assert cache.load("rom", "k") is None
    wall = time.perf_counter()
    with cache.lock("rom", "k"):
        waited = time.perf_counter() - wall
        assert cache.load("rom", "k") is not None  # built by the first holder while we waited
    assert first.wait(timeout=60) == 0
    assert waited > 0.5, waited
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rom-k.npz"]


def test_an_entry_of_another_kind_is_rebuilt_with_a_warning(tmp_path: Path) -> None:
    cache = NpzCache(tmp_path)
    cache.save("basis", "k", {"vectors": np.eye(2), "eigenvalues": np.ones(2), "kinds": np.array(["zero"] * 2),
                              "zeta": 1.0, "gram": np.eye(2), "gram_condition": 1.0})
    os.replace(cache.path("basis", "k"), cache.path("rom", "k"))
    with pytest.warns(CacheWarning, match="is a basis entry, not a rom entry: rebuilt"):
        assert cache.load("rom", "k") is None
    np.savez(cache.path("corrections", "k"), coefficients=np.eye(2))  # a foreign file without the kind entry
    with pytest.warns(CacheWarning, match="without vectors"):
        assert cache.load("corrections", "k") is None
    assert set(KINDS) == {"basis", "corrections", "rom", "reconstruction", "krylov-basis", "model-order",
                          "discretisation-gap", "referee"}


def test_reduce_rebuilds_over_a_wrong_entry_and_two_concurrent_builds_build_once(tmp_path: Path,
                                                                                 monkeypatch: pytest.MonkeyPatch,
                                                                                 capsys: pytest.CaptureFixture[str]
                                                                                 ) -> None:
    work = make_template(tmp_path / "case")
    monkeypatch.chdir(work)
    args = ["reduce", "scene.toml", "--order", "8", "--cache-dir", "c", "--json"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    runs = [subprocess.Popen([sys.executable, "-c", "import sys; from aromm.cli import main; sys.exit(main())",
                              *args], cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            for _ in range(2)]
    outs = [r.communicate(timeout=300) for r in runs]
    assert [r.returncode for r in runs] == [0, 0], outs
    cached = sorted(json.loads(out)["cached"] for out, _ in outs)
    assert cached == [0, 1], outs  # one built, the other waited and loaded it
    assert not [p.name for p in (work / "c").iterdir() if not p.name.endswith(".npz")]
    basis = next((work / "c").glob("basis-*.npz"))
    for rom in (work / "c").glob("rom-*.npz"):  # the model's key and the engine's (aromm.reduction.model_key)
        shutil.copyfile(basis, rom)  # a valid entry of another kind at the model's keys
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "is a basis entry, not a rom entry: rebuilt" in captured.err
    assert json.loads(captured.out)["cached"] == 0


def test_a_damaged_or_non_finite_entry_is_rebuilt_with_one_warning(tmp_path: Path) -> None:
    cache = NpzCache(tmp_path)
    cache.path("rom", "k").write_bytes(b"PK\x03\x04 not a zip archive")
    with pytest.warns(CacheWarning, match="is damaged .*: rebuilt"):
        assert cache.load("rom", "k") is None
    nan = np.full((2, 2), np.nan)
    cache.save("rom", "k", {"capacity.names": ["c"], "conductance.names": ["k"], "capacity.op0": nan})
    with pytest.warns(CacheWarning, match="non-finite values in capacity.op0"):
        assert cache.load("rom", "k") is None


def test_sigterm_unwinds_a_build_like_ctrl_c(tmp_path: Path) -> None:
    """What a batch scheduler sends: one line, exit 143, the build's lock removed and no entry written."""
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), "AROMM_CACHE_DIR": str(tmp_path)}
    code = "import sys; from aromm.cli import main; sys.exit(main(sys.argv[1:]))"
    build = subprocess.Popen([sys.executable, "-c", code, "reduce", str(root / "data" / "scenes" / "wood_s1.toml"),
                              "--order", "40"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob("*.lock")) and build.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert build.poll() is None, build.communicate()
    build.terminate()
    _, err = build.communicate(timeout=120)
    assert build.returncode == 143, err.decode()
    assert err.decode().strip().splitlines()[-1] == "aromm: terminated (SIGTERM); nothing half-written was kept"
    assert not list(tmp_path.glob("*.lock")) and not list(tmp_path.glob("rom-*.npz"))
