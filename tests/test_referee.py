"""A modal model certified over a box through a Krylov referee (aromm.reduction.referee).

Truth: the full semi-discrete model exact in time (aromm.full.exact), independent of both reduced models.  The
bound through the referee must hold (≥ the actual error) and meet the issue's effectivity target where the direct
bound alone misses it by far (asserted, so these tests fail without the referee).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_certificate import BOX, INSIDE, OUTSIDE, against_truth, body

from aromm.api import reduce
from aromm.core.vocabulary import FaceSpec
from aromm.reduction.rom import from_arrays, to_arrays


@pytest.mark.filterwarnings("ignore::aromm.core.errors.ModelWarning")
def test_the_amalgam_with_a_fixed_face_is_certified_sharply_through_its_referee() -> None:
    """Amalgam of order 12 with a fixed-temperature face: the direct bound is 9–22× its actual error (asserted > 3×,
    so the test fails without the referee); through a Krylov referee over the box (its own bound 1e-7 °C, the
    amalgam's error 1e-2) the bound is the amalgam's distance to the referee plus the referee's bound: ≤ 3× inside
    the box (measured 1.00), and ≥ the actual error everywhere."""
    system = body([FaceSpec("z0", flux=500.0), FaceSpec("z1", T=10.0)])
    rom = reduce(system, order=12, method="aromm", bounds=BOX, cache=False)
    assert rom.finer is not None and rom.finer.box and rom.certificate is not None
    assert "referee" in str(rom.info["certificate"]) and float(rom.info["referee_bound"]) > 0
    direct = []
    for mu, (actual, bound, alone, floor) in zip(INSIDE + OUTSIDE, against_truth(rom, system, INSIDE + OUTSIDE),
                                                 strict=True):
        assert np.all(bound >= actual - floor), (mu, bound, actual)
        if mu in INSIDE:  # the worst over the outputs, as the table (the fixed face's own error is 0)
            assert np.max(bound) <= 3 * np.max(actual), (mu, bound, actual)
        direct.append(float(np.max(alone) / np.max(actual)))
    assert min(direct) > 3
    worst = max(float(np.max(b)) for b in (rom.error_bound(mu) for mu in INSIDE) if b is not None)
    assert float(rom.info["error_bound"]) >= worst * (1 - 1e-9)  # the training grid's worst covers the box


def test_the_referee_survives_the_cache_format_and_each_box_has_its_own(tmp_path: object) -> None:
    """The referee is stored with the model (its bound unchanged by the round trip).  The modal model is one entry of
    the cache whatever the box (it serves every value): a second box loads it and takes another referee, a box seen
    before loads both."""
    system = body([FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)], size=5)
    rom = reduce(system, order=8, method="aromm", bounds=BOX, cache=False)
    again = from_arrays(to_arrays(rom))
    assert again.finer is not None and again.finer.order == rom.finer.order  # type: ignore[union-attr]
    first, second = rom.error_bound(INSIDE[0]), again.error_bound(INSIDE[0])
    assert first is not None and second is not None
    np.testing.assert_allclose(second, first, rtol=1e-12)
    cache = str(tmp_path)
    one = reduce(system, order=8, method="aromm", bounds=BOX, cache=cache)
    other = reduce(system, order=8, method="aromm", bounds={"fibre.k": (0.1, 0.5)}, cache=cache)
    same = reduce(system, order=8, method="aromm", bounds=BOX, cache=cache)
    assert int(one.info["cached"]) == 0 and int(other.info["cached"]) == 1 and int(same.info["cached"]) == 1
    assert other.finer is not None and one.finer is not None and same.finer is not None
    assert other.finer.box != one.finer.box and same.finer.box == one.finer.box
    assert float(other.info["error_bound"]) != float(one.info["error_bound"])  # over its own box


def test_a_warm_call_loads_the_worst_bound_over_the_box(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A scene's amalgam and its referee come from the cache on the second call, and so does the worst bound over the
    box (evaluated once: every training point's bound is the warm path's cost otherwise); the same value both times."""
    from inverse_cases import twin_case

    from aromm.reduction import referee
    from aromm.scene.scene_file import load_scene

    scene = load_scene(twin_case(tmp_path)[0])
    counted = []
    original = referee.worst_bound
    monkeypatch.setattr(referee, "worst_bound", lambda *a: counted.append(1) or original(*a))
    box = {"fibre.k": (0.1, 0.5), "fibre.c": (1e6, 1e7)}
    first = reduce(scene, order=8, method="aromm", bounds=box, cache=tmp_path / "cache")
    second = reduce(scene, order=8, method="aromm", bounds=box, cache=tmp_path / "cache")
    assert int(second.info["cached"]) == 1 and "referee" in str(second.info["certificate"])
    assert len(counted) == 1 and float(second.info["error_bound"]) == float(first.info["error_bound"])
