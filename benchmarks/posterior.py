"""MCMC posterior against the linearised intervals, and what the sampling costs with the reduced model.

[Chavez2020]'s scenario 1 (500 W/m² into z0, h = 20 W/(m² K) on z1) on a spruce-like VER (aromm.studies.chavez2020.
small_wood, n³ voxels); twin data: the reduced model itself at k_F = 0.3 W/(m K), c_F = 4e6 J/(m³ K) plus
Gaussian noise of 0.02 °C (so the model is exact and only the statistics are compared).  For each
experiment (the full 60 s, and a short 3 s one observing z0 only, where the data constrain the unknowns
less and the model is less linear over the posterior) it prints:

* the least-squares estimates and their linearised 95 % intervals (inverse.uncertainty, at the known σ);
* the posterior (emcee, σ known, and σ sampled): means, 95 % credible intervals, the ratio of the
  interval widths posterior / linearised, and the posterior mean's offset from the estimate in posterior sd;
* the cost: evaluations, CPU and wall seconds, ms per evaluation, the autocorrelation times and effective
  sample sizes, the acceptance; and one full-model evaluation of the same experiment (BDF2 up to its last
  time), for the cost of the same chain with the full model.

    python benchmarks/posterior.py                          # n = 12, order 40, 2000 steps × 32 walkers
    python benchmarks/posterior.py --size 16 --steps 4000 --json out.json
    python benchmarks/posterior.py --method krylov          # the eigen-free model (aromm.reduction.krylov) over BOUNDS

Measured 2026-12-01 at 24³ (``--size 24 --steps 100``, load average 5–13 on 2 shared cores): krylov order 50 against
the amalgam at order 200 — the identification (60 s experiment, 645 / 650 evaluations) 0.73 vs 8.67 CPU s, an
evaluation in the posterior 1.07 vs 11.4 ms CPU (a 1e4-sample posterior ≈ 11 vs 114 CPU s), the same estimates to
six digits (k_F 0.299978, c_F 4.00047e6; twin data of each model, so this checks the inverse loop, not accuracy).
Measured 2026-12-02 (``--size 24 --method krylov --order 50 --steps 313 --walkers 32``, load ≈ 3; record in
benchmarks/records/posterior_krylov_24.json): a 1e4-sample posterior of the 60 s experiment, 10,048 evaluations in
9.4 CPU s (0.94 ms each; σ sampled 9.5 s), the identification 0.58 CPU s for 645 evaluations.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.stats as st

from aromm.full.solve import simulate
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble
from aromm.studies.chavez2020 import BASIS_VALUES, REFERENCE_VALUES, loading, small_wood
from inverse.identification import identify
from inverse.measurements import Measurements
from inverse.posterior import sample_posterior

TRUTH = {"fibre.k": 0.3, "fibre.c": 4e6}
BOUNDS = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}
NOISE = 0.02


def experiment(rom, system, data: Measurements, *, steps: int, walkers: int,  # type: ignore[no-untyped-def]
               seed: int) -> dict[str, object]:
    start = time.process_time()
    simulate(system, TRUTH, data.t)
    full_s = time.process_time() - start  # one full-model evaluation of this experiment (CPU s)
    start = time.process_time()
    fit = identify(rom, data, BOUNDS, seed=seed)
    identify_s = time.process_time() - start
    unc = fit.uncertainty
    se = unc.std_error * NOISE / unc.residual_std  # linearised standard errors at the known σ
    z = float(st.norm.ppf(0.975))
    est = np.array([fit.estimates[n] for n in unc.names])
    out: dict[str, object] = {"estimates": dict(fit.estimates), "linearised95": {
        n: [float(est[i] - z * se[i]), float(est[i] + z * se[i])] for i, n in enumerate(unc.names)},
        "linearised_correlation": float(unc.correlation[0, 1]), "residual_std": float(unc.residual_std),
        "full_model_s": full_s, "identify_cpu_s": identify_s, "identify_evaluations": fit.evaluations}
    for label, noise in (("known", NOISE), ("sampled", None)):
        post = sample_posterior(rom, data, BOUNDS, steps=steps, walkers=walkers, noise_std=noise, start=fit,
                                rng=np.random.default_rng(seed))
        lower, upper = post.interval
        p = len(unc.names)
        out[f"posterior_{label}"] = {
            "mean": post.mean.tolist(), "interval95": [lower.tolist(), upper.tolist()],
            "width_ratio": ((upper[:p] - lower[:p]) / (2 * z * se)).tolist(),
            "mean_offset_sd": ((post.mean[:p] - est) / post.std[:p]).tolist(),
            "correlation": float(post.correlation[0, 1]),
            "tau": post.autocorr_time.tolist(), "ess": post.effective_samples.tolist(),
            "acceptance": post.acceptance, "evaluations": post.evaluations, "cpu_s": post.cpu_seconds,
            "wall_s": post.seconds, "ms_per_evaluation_cpu": 1e3 * post.cpu_seconds / post.evaluations,
            "warnings": list(post.warnings), "names": list(post.names),
        }
    return out


def report(label: str, res: dict[str, object]) -> None:
    full_s = float(res["full_model_s"])  # type: ignore[arg-type]
    print(f"\n== {label}: residual std {res['residual_std']:.4f} °C (noise {NOISE} °C); identify "
          f"{res['identify_cpu_s']:.2f} CPU s for {res['identify_evaluations']} evaluations")
    est, lin = res["estimates"], res["linearised95"]
    for name in BOUNDS:
        print(f"  {name}: estimate {est[name]:.6g} (truth {TRUTH[name]:g}), linearised 95 % "  # type: ignore[index]
              f"[{lin[name][0]:.6g}, {lin[name][1]:.6g}]")  # type: ignore[index]
    for kind in ("known", "sampled"):
        post = res[f"posterior_{kind}"]
        assert isinstance(post, dict)
        print(f"  posterior, σ {kind}:")
        for i, name in enumerate(post["names"]):
            lo, hi = post["interval95"][0][i], post["interval95"][1][i]
            extra = (f", width / linearised {post['width_ratio'][i]:.3f}, mean − estimate "
                     f"{post['mean_offset_sd'][i]:+.3f} sd") if i < len(BOUNDS) else ""
            print(f"    {name}: mean {post['mean'][i]:.6g}, 95 % [{lo:.6g}, {hi:.6g}]{extra}, τ {post['tau'][i]:.1f}, "
                  f"ESS {post['ess'][i]:.0f}")
        print(f"    correlation {post['correlation']:+.3f} (linearised {res['linearised_correlation']:+.3f}); "
              f"acceptance {post['acceptance']:.3f}; {post['evaluations']} evaluations in {post['cpu_s']:.1f} s CPU "
              f"({post['wall_s']:.1f} s wall), {post['ms_per_evaluation_cpu']:.3f} ms CPU per evaluation; the full "
              f"model would take {post['evaluations'] * full_s / 3600:.1f} h CPU ({full_s:.3f} s per evaluation)")
        for w in post["warnings"]:
            print(f"    warning: {w}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=12)
    parser.add_argument("--order", type=int, default=40)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--walkers", type=int, default=32)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--method", choices=("aromm", "krylov"), default="aromm",
                        help="reduced model: the amalgam, or aromm.reduction.krylov over BOUNDS "
                             "(order = the largest order)")
    args = parser.parse_args()
    scene = loading(small_wood(args.size), "z", end=60.0, dt=0.1)
    system = assemble(scene)
    with tempfile.TemporaryDirectory() as tmp:
        options = {"method": "krylov", "bounds": BOUNDS} if args.method == "krylov" else {
            "basis_values": BASIS_VALUES, "reference_values": REFERENCE_VALUES}
        rom = reduce(system, args.order, cache=tmp, **options)  # type: ignore[arg-type]
    rng = np.random.default_rng(args.seed)
    long = rom.simulate(TRUTH).with_noise(NOISE, rng)
    short_t = np.arange(0.1, 3.0 + 1e-9, 0.1)
    short = rom.simulate(TRUTH, short_t)
    short = Measurements(short.t, {"z0": short.mean_T["z0"]}).with_noise(NOISE, rng)
    results = {}
    print(f"{args.size}³ voxels ({system.n} nodes), {args.method} reduced order {rom.order}, {args.walkers} walkers × "
          f"{args.steps} steps; load average {os.getloadavg()[0]:.1f} (shared 2-core machine)")
    for label, data in (("60 s, z0 and z1", long), ("3 s, z0 only", short)):
        results[label] = experiment(rom, system, data, steps=args.steps, walkers=args.walkers, seed=args.seed)
        report(label, results[label])
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    print(f"\npeak RSS {peak:.0f} MB; load average {os.getloadavg()[0]:.1f}")
    if args.json is not None:
        args.json.write_text(json.dumps({"results": results, "peak_rss_mb": peak}, indent=1))


if __name__ == "__main__":
    main()
