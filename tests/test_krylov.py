"""The eigen-free rational-Krylov reductor (aromm.reduction.krylov, method="krylov") against independent truths: the
exact solution of the full semi-discrete model (dense eigendecomposition, tests/test_reduced.py), the exact 1-D
solution of a layered body and of a slab between fixed temperatures (tests/slab1d.py), the full transfer
function at the interpolation points (moment matching), energy conservation at contrast 1e3."""

from __future__ import annotations

import ast
import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from layered import TIMES, layered_reference, layered_system
from slab1d import Slab, solve
from test_reduced import exact_outputs, random_labels

from aromm.core.errors import InputError
from aromm.core.profiles import Profile
from aromm.core.system import ThermalSystem, TimeGrid, dense
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.reduction.krylov import ESTIMATE_SAFETY, KrylovReductor, build_span
from aromm.reduction.offline import reduce
from aromm.reduction.rom import one_blas_thread
from aromm.reduction.scipy_engine import ScipyEngine
from aromm.reduction.training_box import centre, training_set
from aromm.scene.scene_file import load_scene

BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}
CORNERS = [{"fibre.k": k, "fibre.c": c} for k in (0.1, 1.0) for c in (1e6, 1e7)]
RTOL = 1e-10  # of the shifted solves


@pytest.fixture(autouse=True)
def _one_blas_thread() -> Iterator[None]:
    """Dense truths of a few hundred unknowns: threaded BLAS only fights for the shared cores (50× slower)."""
    with one_blas_thread():
        yield


def two_phase(n: int, contrast: float, faces: list[FaceSpec] | None = None, seed: int = 3) -> ThermalSystem:
    """Random n³ fibre/gas body, gas k and c smaller by ``contrast``; scenario 1 by default (flux z0, h on z1)."""
    phases = [PhaseSpec("gas", 0, 0.3 / contrast, 4e6 / contrast), PhaseSpec("fibre", 1, 0.3, 4e6)]
    faces = faces if faces is not None else [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)]
    return assemble_voxels(random_labels(n, seed=seed), (1e-4,) * 3, phases, faces, time=TimeGrid(20.0, 0.1),
                           outputs=["z0", "z1"])


def test_layered_body_with_histories_and_initial_field_is_exact() -> None:
    """Flux pulse, ramped T_ext, T0 = 1 °C: the layered body's response lives in a space of its 13 node planes,
    which the moments span; the model then equals the exact 1-D solution to round-off over the box, with
    fibre.k, fibre.c and then z1.h (an unknown of the box) varied."""
    system = layered_system()
    h_box = {"fibre.k": (0.1, 1.0), "z1.h": (5.0, 80.0)}
    for box, points in ((BOX, CORNERS), (h_box, [{"fibre.k": 0.1, "z1.h": 80.0}, {"fibre.k": 0.7, "z1.h": 7.0}])):
        rom = reduce(system, order=30, method="krylov", bounds=box, cache=False)
        assert rom.info["method"] == "krylov" and int(rom.info["krylov_points"]) >= 2
        for values in ({}, *points):
            ref = layered_reference(values)
            assert np.abs(rom.simulate(values, TIMES).as_array() - ref).max() < 1e-9 * np.ptp(ref), values


def test_moments_match_the_full_transfer_function_at_the_interpolation_points() -> None:
    """H(μ, s) = E (K + sC)⁻¹ F and its derivative −E (K + sC)⁻¹ C (K + sC)⁻¹ F at every chosen point and shift
    equal the Galerkin model's to the solver tolerance [Antoulas2005, ch. 11] (dense solves as the truth)."""
    system = two_phase(5, 10.0)
    reductor = KrylovReductor.over(BOX, max_points=3)
    engine = ScipyEngine(system)
    assert system.time is not None
    shifts = reductor.shift_values(system.time)
    span = build_span(engine, reductor, tuple((k, *v) for k, v in sorted(BOX.items())), system.time.times, shifts,
                      max_width=10**6)
    assert len(span.points) == 3 and span.points[0] == centre(tuple((k, *v) for k, v in sorted(BOX.items())))
    _, e = system.observation_matrix()
    # the excited inputs: h T_ext on z1 has T_ext = 0 over the whole box, so it gets no moments
    excited = [i for i, t in enumerate(system.load.terms) if float(t.coefficient(system.values())) != 0.0]
    assert len(excited) == 1
    f = np.column_stack([np.asarray(system.load.terms[i].operator) for i in excited])
    model = span.model.projected
    fr = np.column_stack([np.asarray(model.load.terms[i].operator) for i in excited])
    for mu in span.points:
        v = system.values(mu)
        k, c = dense(system.conductance.evaluate(v)), dense(system.capacity.evaluate(v))
        kr, cr = model.conductance.evaluate(v), model.capacity.evaluate(v)
        for s in shifts:
            x = np.linalg.solve(k + s * c, f)
            xr = np.linalg.solve(kr + s * cr, fr)
            h, hr = e @ x, model.observation_matrix()[1] @ xr
            dh, dhr = e @ np.linalg.solve(k + s * c, c @ x), model.observation_matrix()[1] @ np.linalg.solve(
                kr + s * cr, cr @ xr)
            scale = np.abs(h).max()
            assert np.abs(hr - h).max() < 1e3 * RTOL * scale, (mu, s)
            assert np.abs(dhr - dh).max() < 1e3 * RTOL * np.abs(dh).max(), (mu, s)


@pytest.mark.parametrize("contrast", [1.0, 1e3])
def test_converges_to_the_exact_full_model_over_the_box(contrast: float) -> None:
    """Against the exact full model (dense eigendecomposition, exact in time): the whole span (no compression)
    is within 1e-6 of the output range at the corners and centre of the box, at contrast 1 and 1e3, and the
    output-aware Gramian compression to order 80 stays within 1e-5 of it (measured at 7³: span 1.2e-8 °C, order 80
    5.7e-8 °C at contrast 1e3, range 30 °C).  Every modal rate is >= 0: the Galerkin model stays stable."""
    system = two_phase(6, contrast)
    times = system.time.times if system.time is not None else np.zeros(0)
    whole = reduce(system, order=10**4, method=KrylovReductor.over(BOX, tolerance=1e-7), cache=False)
    small = reduce(system, order=80, method=KrylovReductor.over(BOX, tolerance=1e-7, compression="gramian"),
                   cache=False)
    assert small.order == 80 < whole.order
    for values in (*CORNERS, {}):
        ref = exact_outputs(system, values, times)
        assert np.abs(whole.simulate(values, times).as_array() - ref).max() < 1e-6 * np.ptp(ref), values
        assert np.abs(small.simulate(values, times).as_array() - ref).max() < 1e-5 * np.ptp(ref), values
        assert whole.rates(values).min() >= 0.0 and small.rates(values).min() >= 0.0


def test_adiabatic_body_conserves_energy_at_contrast_1e3() -> None:
    """The constant is in every basis, so the stored heat 1ᵀ C(μ) Ψ X(t) of an adiabatic body heated by q is
    q A t exactly, at any order and anywhere in the box."""
    q, n = 500.0, 5
    system = two_phase(n, 1e3, [FaceSpec("z0", flux=q)])
    rom = reduce(system, order=12, method="krylov", bounds=BOX, cache=False, fields=True)
    assert rom.basis is not None and rom.order in (10, 11, 12)  # "auto" compression: 80, 90 or 100 % of the order
    t = np.linspace(0.0, 20.0, 11)
    for values in CORNERS:
        c = system.capacity.evaluate(system.values(values))
        heat = (np.ones(system.n) @ (c @ rom.basis)) @ rom.states(values, t).T
        np.testing.assert_allclose(heat, q * (n * 1e-4) ** 2 * t, rtol=1e-9, atol=1e-9 * q * (n * 1e-4) ** 2)


def test_slab_between_fixed_temperatures_is_lifted_and_exact() -> None:
    """A slab held at 25 °C on z0 and at a moving temperature on z1 (lifted fixed temperatures, their histories and
    derivatives as inputs) equals the exact 1-D solution at the mid plane over a box of conductivities; an output on
    a fixed face (z0) is its known value."""
    nz, k, c, length = 16, 33.0, 7.02e6, 0.1
    tau = length**2 * c / k
    moving = Profile((0.0, 0.02 * tau, 0.05 * tau), (25.0, 100.0, 60.0))
    system = assemble_voxels(np.zeros((1, 1, nz), dtype=int), (length, length, length / nz),
                             [PhaseSpec("steel", 0, k, c)], [FaceSpec("z0", T=25.0), FaceSpec("z1", T=moving)],
                             time=TimeGrid(0.2 * tau, 0.2 * tau / 200), initial_T=25.0, outputs=["x0", "z0"])
    rom = reduce(system, order=20, method="krylov", bounds={"steel.k": (20.0, 50.0)}, cache=False)
    assert rom.info["lifted_faces"] == 2
    times = np.array([0.02, 0.05, 0.1, 0.2]) * tau
    for kk in (20.0, 33.0, 50.0):
        semi = solve(Slab(np.full(nz, kk), np.full(nz, c), length / nz), times, fixed_first=lambda t: 25.0,
                     fixed_last=lambda t: float(moving(t)), initial=25.0, breaks=moving.times)
        planes = semi[:, :] if semi.ndim == 2 else semi
        # the x0 face mean weighs the node planes by the 1-D trapezoid rule of the face (Q1 face mass)
        weights = np.full(nz + 1, 1.0 / nz)
        weights[[0, -1]] /= 2
        outputs = rom.simulate({"steel.k": kk}, times).as_array()
        assert np.abs(outputs[:, 0] - planes @ weights).max() < 1e-6
        assert np.abs(outputs[:, 1] - 25.0).max() < 1e-9  # an output on a fixed face: its known value


def test_cache_fields_and_scene_key(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    """A second build is loaded from the cache; fields reproduce the outputs; the scene's [reduction] method and
    bounds select the reductor (also for `aromm reduce`) and bad values are refused naming the key."""
    system = two_phase(4, 10.0)
    first = reduce(system, order=10, method="krylov", bounds=BOX, cache=tmp_path)
    again = reduce(system, order=10, method="krylov", bounds=BOX, cache=tmp_path)
    assert first.info["cached"] == 0 and again.info["cached"] == 1
    t = np.array([1.0, 5.0])
    np.testing.assert_array_equal(again.simulate(CORNERS[0], t).as_array(), first.simulate(CORNERS[0], t).as_array())
    with_fields = reduce(system, order=10, method="krylov", bounds=BOX, cache=tmp_path, fields=True)
    obs = with_fields.simulate(CORNERS[1], t, fields=True)
    _, e = system.observation_matrix()
    assert obs.fields is not None
    np.testing.assert_allclose(obs.fields @ e.T, obs.as_array(), rtol=1e-12, atol=1e-12)
    scene = tmp_path / "s.toml"
    np.savez(tmp_path / "img.npz", labels=random_labels(4, seed=1))
    from scene_text import scenario_1

    text = scenario_1("img.npz", "5.0e-6", "2.0", "0.1") + '\n[reduction]\nmethod = "krylov"\n'
    scene.write_text(text + 'bounds = { "fibre.k" = [0.1, 1.0] }\n')
    sc = load_scene(scene)
    assert sc.reduction.method == "krylov" and sc.reduction.bounds == {"fibre.k": (0.1, 1.0)}
    from aromm.cli import main

    assert main(["reduce", str(scene), "--order", "8", "--cache-dir", str(tmp_path / "c"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "krylov" and out["order"] <= 8 and out["solves"] > 0
    assert out["compression"].split("@")[0] in ("gramian", "greedy", "pod")  # the rule auto kept
    for bad, key in (('bounds = { "fibre.k" = [1.0, 0.1] }', "reduction.bounds.fibre.k"),
                     ('bounds = { "nope.k" = [0.1, 1.0] }', "reduction.bounds.nope.k")):
        scene.write_text(text + bad + "\n")
        with pytest.raises(InputError, match=key):
            load_scene(scene)


def test_the_greedy_tolerance_is_a_knob_of_reduce_the_scene_and_the_cli(tmp_path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    """``tolerance`` (°C) stops the greedy at an estimated error below tolerance / ESTIMATE_SAFETY; a tighter one
    is another model (not the cached one) with at least as many points; it asks "auto" for the Krylov method, and
    a modal method refuses it; the scene's ``[reduction] tolerance`` and ``aromm reduce --tolerance`` set it."""
    system = two_phase(4, 10.0)
    loose = reduce(system, order=30, tolerance=1e-2, bounds=BOX, cache=tmp_path)
    tight = reduce(system, order=30, tolerance=1e-8, bounds=BOX, cache=tmp_path)
    assert loose.info["method"] == tight.info["method"] == "krylov" and tight.info["cached"] == 0
    assert float(loose.info["krylov_estimate"]) <= 1e-2 / ESTIMATE_SAFETY
    assert int(tight.info["krylov_points"]) > int(loose.info["krylov_points"])
    with pytest.raises(InputError, match="tolerance belongs to method 'krylov'"):
        reduce(system, order=10, tolerance=1e-6, method="aromm", cache=False)
    np.savez(tmp_path / "img.npz", labels=random_labels(4, seed=1))
    from scene_text import scenario_1

    scene = tmp_path / "s.toml"
    text = scenario_1("img.npz", "5.0e-6", "2.0", "0.1") + '\n[reduction]\nbounds = { "fibre.k" = [0.1, 1.0] }\n'
    scene.write_text(text + "tolerance = 1e-6\n")
    assert load_scene(scene).reduction.tolerance == 1e-6
    scene.write_text(text + "tolerance = -1e-6\n")
    with pytest.raises(InputError, match=r"reduction\.tolerance"):
        load_scene(scene)
    scene.write_text(text)
    from aromm.cli import main

    assert main(["reduce", str(scene), "--order", "8", "--tolerance", "1e-2", "--no-cache", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "krylov" and float(out["krylov_estimate"]) <= 1e-2 / ESTIMATE_SAFETY


def test_bad_options_are_refused_before_any_solve() -> None:
    system = two_phase(3, 1.0)
    with pytest.raises(InputError, match="unknown parameter"):
        reduce(system, order=5, method="krylov", bounds={"nope.k": (0.1, 1.0)}, cache=False)
    for options in ({"tolerance": -1.0}, {"rtol": 2.0}, {"shifts": 0}, {"compression": "svd"}):
        with pytest.raises(InputError):
            KrylovReductor.over(BOX, **options)
    with pytest.raises(InputError, match="lower"):
        KrylovReductor.over({"fibre.k": (1.0, 0.1)})
    assert len(training_set((("a", 1.0, 4.0), ("b", 1.0, 1.0)))) == 5


class _Stop(RuntimeError):
    pass


def test_a_default_box_of_many_axes_is_said_before_any_solve(caplog: pytest.LogCaptureFixture,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """Four phases and no bounds: the default box has eight axes (k and c of each), trained on a Sobol set that costs
    minutes; the build says so, naming the remedy, before its first shifted solve, and only then; with bounds it is
    silent."""
    labels = np.random.default_rng(5).integers(0, 4, (4, 4, 4))
    phases = [PhaseSpec(f"p{i}", i, 0.1 * (i + 1), 1e6 * (i + 1)) for i in range(4)]
    system = assemble_voxels(labels, (1e-4,) * 3, phases, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)],
                             time=TimeGrid(5.0, 0.5), outputs=["z1"])

    def stop(*_: object, **__: object) -> None:
        raise _Stop

    monkeypatch.setattr(ScipyEngine, "shifted_solve", stop)
    for bounds, said in ((None, 1), ({"p0.k": (0.05, 0.2)}, 0)):
        caplog.clear()
        with caplog.at_level("WARNING", logger="aromm.reduction.training_box"), pytest.raises(_Stop):
            reduce(system, order=10, method="krylov", bounds=bounds, cache=False)
        notes = [r.getMessage() for r in caplog.records if "no bounds given" in r.getMessage()]
        assert len(notes) == said, notes
        assert all("8 axes" in n and "[reduction] bounds" in n and "--unknown" in n for n in notes)


def test_a_system_without_free_outputs_is_refused_before_any_solve() -> None:
    """The reduction is output-aware: no outputs, or outputs only on fixed-temperature faces, is an input error."""
    labels = random_labels(5)
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4.0e6)]
    faces = [FaceSpec("z0", T=25.0), FaceSpec("z1", T=100.0)]
    for outputs, match in (((), "needs outputs"), (("z0", "z1"), "fixed-temperature faces")):
        system = assemble_voxels(labels, (1e-4,) * 3, phases, faces, time=TimeGrid(1.0, 0.1), initial_T=25.0,
                                 outputs=outputs)
        with pytest.raises(InputError, match=match):
            reduce(system, order=10, method="krylov", bounds=BOX, cache=False)


def test_the_reductor_sees_only_the_engine_protocol() -> None:
    """aromm.reduction.krylov imports no engine implementation and no sparse algebra (a PETSc engine can plug in)."""
    tree = ast.parse(Path(__file__).resolve().parents[1].joinpath("aromm", "reduction", "krylov.py").read_text())
    names = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)} | \
        {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    assert "aromm.reduction.engine_protocol" in names
    assert not any(n and ("scipy" in n or "petsc" in n or n == "aromm.linalg.direct") for n in names), names


def test_every_reduction_method_a_scene_may_name_is_implemented() -> None:
    """The scene's [reduction] method names are the reductors by name, the eigen-free Krylov method, and "auto",
    which picks one of the two by size (the amalgam up to KRYLOV_ABOVE free unknowns)."""
    from aromm.reduction.offline import REDUCTORS
    from aromm.scene.reduction_section import KRYLOV_ABOVE, REDUCTION_METHODS, ReductionSettings

    assert set(REDUCTORS) | {"krylov", "auto"} == set(REDUCTION_METHODS)
    auto = ReductionSettings()
    assert auto.method == "auto"
    assert (auto.method_for(KRYLOV_ABOVE), auto.method_for(KRYLOV_ABOVE + 1)) == ("aromm", "krylov")
    assert ReductionSettings(method="pod").method_for(10 * KRYLOV_ABOVE) == "pod"
    # a modal option, or reference cases, ask for the amalgam; the Krylov reduction refuses modal options
    assert ReductionSettings(modes=40).method_for(10 * KRYLOV_ABOVE) == "aromm"
    assert auto.method_for(10 * KRYLOV_ABOVE, references=True) == "aromm"
    with pytest.raises(InputError, match="modes belong to the modal methods"):
        ReductionSettings(method="krylov").updated(modes=40)
