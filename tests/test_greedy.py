"""POD-greedy reductor (aromm.reduction.greedy) and shifted-solve corrections (aromm.reduction.shifted).

Independent truths: the exact outputs of the full FE system by dense generalised eigendecomposition
(tests/test_reduced.exact_outputs) and, for the shifts, the transfer function e (K + sC)⁻¹ F by a sparse solve.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from test_reduced import exact_outputs, random_labels, system_of

from aromm.core.errors import InputError
from aromm.reduction.greedy import PodGreedy, pod_greedy, training_grid
from aromm.reduction.offline import reduce
from aromm.reduction.reductors import snapshot_times
from aromm.reduction.rom import ReducedModel
from aromm.reduction.shifted import SHIFT, default_shifts, shifted_samples

TRAINING = [{"fibre.k": k, "fibre.c": c} for k in (0.05, 1.0) for c in (1e5, 1e7)]
TARGET = 1e-6  # °C, on face means of about 1 °C


def test_greedy_error_decreases_to_its_target_against_the_exact_full_model() -> None:
    system = system_of(random_labels(4, seed=5))  # 125 unknowns: the detailed model is the FE model itself
    detailed = ReducedModel.from_system(system, np.eye(system.n))
    values = system.values()
    cap = system.capacity.evaluate(values).toarray()
    ones = np.ones((system.n, 1))
    times = snapshot_times(system.time)
    own = [{k: v for k, v in {**values, **mu}.items() if k in detailed.parameter_names} for mu in TRAINING]
    result = pod_greedy(detailed, own, times, 60, kept=ones / np.sqrt(ones.T @ cap @ ones), gram=cap,
                        tolerance=TARGET, step=2)
    history = result.history
    assert history[-1] <= TARGET < history[0]
    assert result.orders[-1] < 60  # stopped by the target, not by the order
    # the error falls by orders of magnitude: each third of the run ends lower than the one before
    thirds = np.array_split(history, 3)
    assert thirds[0].min() > thirds[1].min() > thirds[2].min()
    rom = detailed.transform(result.coefficients)
    for mu in TRAINING:
        exact = exact_outputs(system, mu, times)
        assert np.abs(rom.simulate(mu, times).as_array() - exact).max() <= TARGET * (1 + 1e-6)


def test_greedy_by_name_and_its_options_key_the_cache(tmp_path) -> None:
    system = system_of(random_labels(3, seed=6))
    by_name = reduce(system, order=8, modes=system.n, method="greedy", cache=tmp_path)
    assert by_name.order == 8 and by_name.info["method"] == "greedy"
    one = reduce(system, order=8, modes=system.n, method=PodGreedy.over(TRAINING[:1]), cache=tmp_path)
    two = reduce(system, order=8, modes=system.n, method=PodGreedy.over(TRAINING[1:]), cache=tmp_path)
    assert one.info["cached"] == two.info["cached"] == 0  # other training sets are other reduced models
    again = reduce(system, order=8, modes=system.n, method=PodGreedy.over(TRAINING[:1]), cache=tmp_path)
    assert again.info["cached"] == 1
    t = system.time.times
    np.testing.assert_array_equal(again.simulate(TRAINING[2], t).as_array(), one.simulate(TRAINING[2], t).as_array())
    assert np.abs(one.simulate(TRAINING[2], t).as_array() - two.simulate(TRAINING[2], t).as_array()).max() > 0


def test_greedy_options_are_checked() -> None:
    with pytest.raises(InputError, match="tolerance"):
        PodGreedy.over(TRAINING, tolerance=-1.0)
    with pytest.raises(InputError, match="no value"):
        training_grid({"fibre.k": 0.3}, ["fibre.c"])
    assert len(training_grid({"a": 1.0, "b": 2.0}, ["a", "b"])) == 9


def test_shifted_corrections_interpolate_the_transfer_function() -> None:
    # A Galerkin basis holding (K + sC)⁻¹F reproduces H(s) = e (K + sC)⁻¹ F exactly at that s.
    system = system_of(random_labels(6, seed=1))
    base = dict(system.parameters)  # the bases' reference values (reduce's default)
    shifts = default_shifts(system.time, 3)
    samples = shifted_samples([base], shifts)
    assert all(s[SHIFT] > 0 for s in samples)
    rom = reduce(system, order=40, modes=30, corrections=samples, cache=False)
    assert rom.info["n_corrections"] > 0
    values = {k: v for k, v in base.items() if k in system.parameter_names}
    full = system.values(values)
    k = sp.csc_array(system.conductance.evaluate(full))
    c = sp.csc_array(system.capacity.evaluate(full))
    f = np.asarray(system.load.evaluate(full))
    _, e = system.observation_matrix()
    reduced_system = rom.projected  # the reduced operators, dense, same affine terms
    red = reduced_system.values(values)
    lr, ar, nr = (np.asarray(g.evaluate(red)) for g in (reduced_system.capacity, reduced_system.conductance,
                                                          reduced_system.load))
    for s in shifts:
        exact = e @ spla.spsolve(k + s * c, f)
        reduced = reduced_system.observation_matrix()[1] @ np.linalg.solve(ar + s * lr, nr)
        np.testing.assert_allclose(reduced, exact, rtol=1e-7)
    with pytest.raises(InputError, match="positive"):
        shifted_samples([base], [0.0])
