"""Outputs of several kinds fitted together: one noise level per kind, estimated with the parameters.

The criterion of [Chavez2020, eq. 12] pools every residual into one variance, which is right when every output is a
temperature.  A coupled heat and moisture model (aromm.physics.hygrothermal) is also observed through relative
humidities (``phi:<face>`` outputs, in 1): their noise is of another size and unit (a thermocouple ±0.05 °C, a
humidity sensor ±0.01), and an unweighted sum lets the temperatures decide alone.  With independent Gaussian noise
of standard deviation σ_k per kind k, the maximum-likelihood estimate minimises
``Σ_k n_k log(Σ_{i∈k} r_i²)``, whose stationary points are those of the weighted least squares
``½ Σ_i (r_i / σ_{k(i)})²`` with ``σ_k² = Σ_{i∈k} r_i² / n_k`` at the estimate [SeberWild1989]: the
iteratively reweighted least squares of :func:`reweighted` reaches it (each round a least-squares refinement from
the last estimate with the σ_k of its residuals).  The weighted residuals then have unit variance in every kind,
so the interval of :func:`inverse.uncertainty.linearised` holds for the pooled problem, and the σ_k are reported.
"""

from __future__ import annotations

import logging

import numpy as np

from aromm.core.system import FloatArray
from inverse import optimisers as opt
from inverse.criterion import LeastSquares

log = logging.getLogger(__name__)

#: Rounds of reweighting at most, and the relative change of every σ_k below which they stop.
ROUNDS = 8
SETTLED = 1e-3


def several(criterion: LeastSquares) -> bool:
    """Whether the measurements hold outputs of more than one kind."""
    return len({str(k) for kinds in criterion.kinds for k in kinds}) > 1


def noise_levels(criterion: LeastSquares, theta: FloatArray) -> dict[str, float]:
    """σ_k (each kind's unit) of the unweighted residuals at the parameters ``theta``: the RMS over its outputs."""
    misfits = list(zip(criterion.misfits(theta), criterion.kinds, strict=True))
    out = {}
    for kind in sorted({str(k) for _, kinds in misfits for k in kinds}):
        parts = [r[:, kinds == kind] for r, kinds in misfits]
        out[kind] = float(np.sqrt(sum(float((p**2).sum()) for p in parts) / sum(p.size for p in parts)))
    return out


def reweighted(criterion: LeastSquares, box: opt.Box, u: FloatArray) -> tuple[FloatArray, dict[str, float]]:
    """The estimate (normalised coordinates of ``box``) and the σ_k per kind of the weighted least squares
    (module docstring), from ``u``; ``criterion`` is left weighted by them."""
    noise = noise_levels(criterion, box.to_physical(u[None])[0])
    for round_ in range(ROUNDS):
        floor = max(noise.values()) * np.finfo(float).eps
        noise = {k: max(v, floor) for k, v in noise.items()}  # an exact kind would take all the weight
        criterion.weigh(noise)
        u = opt.refine(lambda v: criterion.residuals(box.to_physical(v)), u).u
        new = noise_levels(criterion, box.to_physical(u[None])[0])
        change = max(abs(new[k] - noise[k]) / noise[k] for k in noise)
        log.info("identify: noise per kind after round %d: %s (change %.1e)", round_ + 1,
                 ", ".join(f"{k} {v:.3g}" for k, v in new.items()), change)
        noise = new
        if change < SETTLED:
            break
    criterion.weigh(noise)
    return u, noise
