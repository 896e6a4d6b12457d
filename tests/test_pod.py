"""POD baseline: an order beyond what the snapshots span is refused, never capped (issue 15)."""

from __future__ import annotations

import numpy as np
import pytest
from test_reduced import random_labels, system_of

from aromm.core.errors import InputError
from aromm.reduction.offline import reduce
from aromm.reduction.pod import pod_coefficients


def test_order_beyond_the_snapshot_rank_is_refused() -> None:
    # States of rank 3 by construction (Ñ = 12 modes, 40 times) plus one kept column: 4 directions exist.
    rng = np.random.default_rng(0)
    states = rng.standard_normal((12, 3)) @ rng.standard_normal((3, 40))
    gram = np.eye(12) + 0.1 * np.diag(np.arange(12.0))
    kept = np.zeros((12, 1))
    kept[0, 0] = 1.0
    a = pod_coefficients(states, gram, 4, kept)
    assert a.shape == (12, 4)
    np.testing.assert_allclose(a.T @ gram @ a, np.eye(4), atol=1e-10)  # G-orthonormal
    with pytest.raises(InputError, match=r"POD order 5 .* 4 available .* snapshot rank 3"):
        pod_coefficients(states, gram, 5, kept)


def test_reduce_refuses_a_pod_order_its_snapshots_cannot_give(tmp_path) -> None:
    system = system_of(random_labels(4, seed=3))
    with pytest.raises(InputError, match="POD order 100 is more than the snapshots hold") as err:
        reduce(system, order=100, modes=system.n, method="pod", cache=tmp_path)
    available = int(str(err.value).split(" available")[0].rsplit(" ", 1)[1])
    rom = reduce(system, order=available, modes=system.n, method="pod", cache=tmp_path)
    assert rom.order == available  # the largest order the message offers is given in full
