"""How pessimistic a plain energy bound of a reduced model's output error is (issue 35, item 3: groundwork).

For C ė + K e = r (e = T − V X the error of a Galerkin model, r its residual, e(0) = 0), the energy estimates give,
for a face-mean output row E:

    C route: |E e(t)| ≤ ‖E‖_{C⁻¹} (∫₀ᵗ ‖r‖²_{K⁻¹})^{1/2},      K route: |E e(t)| ≤ ‖E‖_{K⁻¹} (∫₀ᵗ ‖r‖²_{C⁻¹})^{1/2}.

Both are computed here exactly on a small body (dense inverses, the residual on a fine time grid with the model's
exact-in-time states, the integral by the rectangle rule), beside the actual worst error against the exact solution
of the full semi-discrete model (dense eigendecomposition).  The ratio bound / actual (the effectivity) is what a
certificate built on these estimates would cost; the target of issue 35 is 1–100.

    python benchmarks/energy_bound.py --size 7 --orders 6 12 20
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.linalg as sla

from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.reduction.offline import reduce

BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}


def exact(system: ThermalSystem, values: dict[str, float], times: np.ndarray) -> np.ndarray:
    """Outputs of the full semi-discrete model at ``times`` (zero initial state, constant loads), exact in time."""
    v = system.values(values)
    k, c = system.conductance.evaluate(v).toarray(), system.capacity.evaluate(v).toarray()
    f = np.asarray(system.load.evaluate(v)).ravel()
    lam, w = sla.eigh(k, c)
    _, e = system.observation_matrix()
    return np.stack([np.asarray(e) @ (w @ ((1 - np.exp(-lam * t)) / lam * (w.T @ f))) for t in times])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=7, help="voxels per side")
    parser.add_argument("--orders", type=int, nargs="+", default=[6, 12, 20])
    parser.add_argument("--steps", type=int, default=4000, help="time steps of the residual's integral")
    args = parser.parse_args()
    labels = (np.random.default_rng(2).random((args.size,) * 3) < 0.4).astype(int)
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
    system = assemble_voxels(labels, (5e-6,) * 3, phases, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)],
                             time=TimeGrid(2.0, 0.05), outputs=["z0", "z1"])
    mu = {"fibre.k": 0.4, "fibre.c": 2e6}
    v = system.values(mu)
    k, c = system.conductance.evaluate(v).toarray(), system.capacity.evaluate(v).toarray()
    f = np.asarray(system.load.evaluate(v)).ravel()
    _, e = system.observation_matrix()
    e = np.asarray(e)
    k_inv, c_inv = np.linalg.inv(k), np.linalg.inv(c)
    times = np.linspace(0.0, 2.0, args.steps + 1)[1:]
    dt = times[1] - times[0]
    truth = exact(system, mu, times)
    print(f"{args.size}³ body, {system.n} unknowns, fibre.k = 0.4, fibre.c = 2e6 (inside the box {BOX})")
    print("order  actual (°C)  C route (°C)  K route (°C)  effectivity C  effectivity K")
    for order in args.orders:
        rom = reduce(system, order=order, method="krylov", bounds=BOX, cache=False, fields=True)
        basis = rom.basis
        assert basis is not None
        x = rom.states(mu, times)
        lr, ar, nr = basis.T @ c @ basis, basis.T @ k @ basis, basis.T @ f
        xdot = np.linalg.solve(lr, (nr[None, :] - x @ ar.T).T).T
        r = f[None, :] - x @ (k @ basis).T - xdot @ (c @ basis).T
        in_k = np.cumsum(np.einsum("ti,ij,tj->t", r, k_inv, r)) * dt
        in_c = np.cumsum(np.einsum("ti,ij,tj->t", r, c_inv, r)) * dt
        route_c = np.sqrt(np.einsum("ki,ij,kj->k", e, c_inv, e)[None, :] * in_k[:, None]).max()
        route_k = np.sqrt(np.einsum("ki,ij,kj->k", e, k_inv, e)[None, :] * in_c[:, None]).max()
        actual = float(np.abs(rom.simulate(mu, times).as_array() - truth).max())
        print(f"{rom.order:5d}  {actual:11.3g}  {route_c:12.3g}  {route_k:12.3g}  {route_c / actual:13.3g}  "
              f"{route_k / actual:13.3g}")


if __name__ == "__main__":
    main()
