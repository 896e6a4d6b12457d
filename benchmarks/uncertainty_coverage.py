"""Coverage of the 95 % intervals of inverse.uncertainty under white and correlated noise.

A straight line y = a + b t fitted to n samples with AR(1) noise of coefficient ρ (R seeded repetitions):
how often the white-noise (Gauss–Newton) interval and the Newey–West/HAC interval (Bartlett kernel,
Andrews' AR(1) bandwidth [NeweyWest1987; Andrews1991]) contain the truth, how often the residual
diagnostics call the residuals systematic, and the mean bandwidth and cost.  The knob is the HAC
window: it is chosen from the data; the table shows what it buys against the white interval.

Usage: python benchmarks/uncertainty_coverage.py [--reps 400] [--seed 1]
"""

from __future__ import annotations

import argparse
import os
import resource
import time
import warnings

import numpy as np
from scipy.signal import lfilter

from inverse.uncertainty import UncertaintyWarning, linearised

CASES = [(0.0, 100), (0.0, 400), (0.5, 100), (0.5, 400), (0.7, 400), (0.9, 400), (0.9, 2000)]


def ar1(rng: np.random.Generator, rho: float, n: int) -> np.ndarray:
    """Stationary AR(1) noise e_i = ρ e_(i-1) + z_i, z_i ~ N(0, 1), e_0 ~ N(0, 1/(1 - ρ²))."""
    z = rng.standard_normal(n)
    z[0] /= np.sqrt(1.0 - rho**2)
    return np.asarray(lfilter([1.0], [1.0, -rho], z))


def coverage(rho: float, n: int, reps: int, rng: np.random.Generator) -> tuple[float, float, float, float, float]:
    t = np.linspace(0.0, 10.0, n)
    x = np.column_stack([np.ones(n), t])
    truth = np.array([1.5, -0.4])
    white = robust = flagged = window = 0.0
    cpu = time.process_time()
    for _ in range(reps):
        y = x @ truth + 0.3 * ar1(rng, rho, n)
        b = np.linalg.lstsq(x, y, rcond=None)[0]
        unc = linearised(("a", "b"), b, x, y - x @ b)
        white += float(np.mean((unc.lower <= truth) & (truth <= unc.upper)))
        robust += float(np.mean((unc.lower_hac <= truth) & (truth <= unc.upper_hac)))
        flagged += unc.residuals.systematic
        window += unc.bandwidth
    return white / reps, robust / reps, flagged / reps, window / reps, (time.process_time() - cpu) / reps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=400)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    warnings.simplefilter("ignore", UncertaintyWarning)
    rng = np.random.default_rng(args.seed)
    wall = time.perf_counter()
    band = 3 * np.sqrt(0.95 * 0.05 / args.reps)
    print(f"{args.reps} repetitions per row; 3 binomial sd around 0.95: ±{band:.3f}")
    print(f"{'rho':>5}{'n':>6}{'white cov.':>12}{'HAC cov.':>10}{'flagged':>9}{'window':>8}{'ms/fit':>8}")
    for rho, n in CASES:
        w, h, f, s, c = coverage(rho, n, args.reps, rng)
        print(f"{rho:5.1f}{n:6d}{w:12.3f}{h:10.3f}{f:9.3f}{s:8.1f}{1e3 * c:8.2f}")
    print(f"wall {time.perf_counter() - wall:.1f} s, CPU {time.process_time():.1f} s, "
          f"peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB, "
          f"load average {os.getloadavg()[0]:.2f} (shared machine)")


if __name__ == "__main__":
    main()
