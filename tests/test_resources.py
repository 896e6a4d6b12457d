"""Resource guards: fields kept only where asked (same values as stored steps), memory refusals before work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from inverse_cases import scenario_system, tracheids
from scene_text import scenario_1

from aromm.cli import main
from aromm.core import resources
from aromm.core.errors import InputError
from aromm.full.solve import interpolate_rows, transient


def test_fields_between_steps_equal_interpolation_of_the_stored_steps() -> None:
    """Rows interpolated as the steps pass == interpolate_rows on every stored grid field (two code paths)."""
    system = scenario_system("z", n=4, end=10.0, dt=1.0)
    grid = transient(system, fields=True)  # rows at every grid time 1, 2, ..., 10
    start = np.full((1, system.n), 0.0)
    t_all, rows = np.concatenate([[0.0], grid.t]), np.vstack([start, grid.fields])
    t_out = np.array([0.0, 0.5, 2.0, 3.25, 9.999999])
    off = transient(system, None, t_out, fields=True)
    assert off.fields is not None and off.fields.shape == (5, system.n)
    np.testing.assert_allclose(off.fields, interpolate_rows(t_out, t_all, rows), rtol=1e-14, atol=1e-14)
    last = transient(system, None, t_out, fields="last")
    assert last.fields is not None and last.fields.shape == (1, system.n)
    np.testing.assert_array_equal(last.fields[0], off.fields[-1])
    np.testing.assert_array_equal(last.as_array(), off.as_array())


@pytest.mark.parametrize(("text", "nbytes"), [("4G", 4 * 2**30), ("512M", 512 * 2**20), ("2.5e9", 2_500_000_000),
                                              ("100 KiB", 100 * 1024)])
def test_memory_limit_parses_units(monkeypatch: pytest.MonkeyPatch, text: str, nbytes: int) -> None:
    monkeypatch.setenv("AROMM_MEMORY_LIMIT", text)
    assert resources.available_memory() == (nbytes, "AROMM_MEMORY_LIMIT")


@pytest.mark.parametrize("text", ["lots", "-1G", "0"])
def test_bad_memory_limit_names_the_variable(monkeypatch: pytest.MonkeyPatch, text: str) -> None:
    monkeypatch.setenv("AROMM_MEMORY_LIMIT", text)
    with pytest.raises(InputError, match="AROMM_MEMORY_LIMIT"):
        resources.available_memory()


def test_available_memory_is_known_on_linux(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("AROMM_MEMORY_LIMIT", raising=False)
    avail, source = resources.available_memory()
    if Path("/proc/meminfo").exists():
        assert avail is not None and avail > 0 and source in ("MemAvailable", "cgroup limit")


def test_transient_that_cannot_keep_its_fields_is_refused_with_the_numbers(monkeypatch: pytest.MonkeyPatch) -> None:
    """4³ voxels = 125 unknowns; 10 field rows are 10 kB: refused under a 8 kB limit, 'last' (1 kB) is not."""
    system = scenario_system("z", n=4, end=10.0, dt=1.0)
    monkeypatch.setenv("AROMM_MEMORY_LIMIT", "8K")
    with pytest.raises(InputError, match=r"would keep .* GB \(11 times × 2 outputs × 2 copies \+ 10 fields × "
                                         r"125 unknowns, 8 bytes each\), more than the .* available"):
        transient(system, fields=True)
    assert transient(system, fields="last").fields is not None


def test_cli_simulate_refuses_what_cannot_fit_with_exit_2(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    np.save(tmp_path / "img.npy", tracheids(4))
    scene = tmp_path / "s.toml"
    scene.write_text(scenario_1("img.npy", "1.0e-4", "1.0e4", "0.01"), encoding="utf-8")  # 1e6 steps
    monkeypatch.setenv("AROMM_MEMORY_LIMIT", "16M")  # 1e6 × 2 outputs × 2 copies × 8 B = 32 MB
    assert main(["simulate", str(scene)]) == 2
    err = capsys.readouterr().err
    assert "would keep 0.032 GB" in err and "raise [time] dt" in err and "Traceback" not in err


def test_reduced_model_refuses_a_batch_that_cannot_fit(monkeypatch: pytest.MonkeyPatch,
                                                       tmp_path: Path) -> None:
    from aromm.reduction.offline import reduce
    from aromm.reduction.rom import MODAL_WORK

    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path))
    rom = reduce(scenario_system("z", n=4, end=10.0, dt=1.0), order=6)
    t = np.arange(1.0, 1001.0)
    need = 8 * 10 * t.size * (MODAL_WORK * rom.order + 2)
    monkeypatch.setenv("AROMM_MEMORY_LIMIT", str(need - 1))
    with pytest.raises(InputError, match=r"the reduced model would keep .* \(10 parameter sets × 1000 times"):
        rom.simulate_batch({"fibre.k": np.full(10, 0.3)}, t)
    monkeypatch.setenv("AROMM_MEMORY_LIMIT", str(need))
    assert rom.simulate_batch({"fibre.k": np.full(10, 0.3)}, t).shape == (10, 1000, 2)
