"""Attach the certified output error bound (:mod:`aromm.reduction.certificate`) to a model built on one process.

Both one-process builds end here: the Krylov reduction (:mod:`aromm.reduction.krylov_offline`, over its training box)
and the modal methods (:mod:`aromm.reduction.offline`: amalgam, POD, greedy, whose basis Ψ = Φ A is a Galerkin basis
of the lifted system like the Krylov one).  Whether a model is certified is :func:`wanted` (by size unless asked);
the certificate's offline cost is one shifted solve per column of M and rung of the σ ladder.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from aromm.core.system import FloatArray, ThermalSystem
from aromm.reduction import krylov
from aromm.reduction.certificate import Certificate, CertifyingEngine, error_bound, ladder
from aromm.reduction.certificate import certify as certificate_of
from aromm.reduction.certificate_gram import GramLedger
from aromm.reduction.rom import ReducedModel
from aromm.reduction.training_box import Box, centre, training_set

#: Left to itself (``certify`` None), a Krylov greedy stops on the certified bound below this many unknowns (and the
#: bound certifies every model built on one process up to :data:`CERTIFY_AFTER_BELOW`).  The certificate's offline cost
#: is one shifted solve per column of M and rung of the σ ladder (three on the shipped scenes), by a sparse Cholesky
#: factor (:data:`~aromm.reduction.scipy_engine.WIDE_BLOCK`); a Krylov build that stops on the bound also runs until
#: the bound, not only its estimate, meets the tolerance.  ``python benchmarks/certified_cost.py --sizes 24 32`` (one
#: BLAS thread, beside a CI run: load 1.7–2.0, 2026-12-05; records/certified_cost_24_32.txt), CPU s certified against
#: without: the generated 24³ wood VER (15,625 unknowns) 32.3 against 4.3 (7.5×, two more greedy points), 32³
#: (35,937) 57.5 against 11.0 (5.2×, 1.27 GB): up to 32³ the certificate costs no more, relatively, than it did by
#: default below 20,000.  On the shipped 46³ VER (103,823; ``aromm reduce data/scenes/wood_s1.toml --certify``, load
#: 2.0–3.3) 311 CPU s and 3.4 GB against 21 CPU s and 0.4 GB (15×: its bound met the tolerance only at the greedy's
#: ten points, and not then).
CERTIFY_BELOW = 40_000
#: Left to itself, a model built on one process of fewer unknowns than this, but not fewer than
#: :data:`CERTIFY_BELOW`, is certified once built: the greedy stops on its estimate, the returned model's bound over
#: the training set is computed and said (a warning when it misses the tolerance), which costs one solve per column of
#: the compressed model's M (inputs, outputs, terms × order) and rung, not of the greedy's whole span.  The same
#: limit as the wide blocks' direct solves (:data:`~aromm.reduction.scipy_engine.WIDE_DIRECT_BELOW`): above it they
#: iterate, at several times the cost per column.  Measured (``python benchmarks/certified_cost.py --sizes 16 46``,
#: records/certified_cost_16_46.txt): the generated 46³ VER 14.5 CPU s without, 87.5 certified once built, 129.1 with
#: the greedy stopping on the bound; the shipped one 19, 115 and 250 (docs/method/krylov.md).
CERTIFY_AFTER_BELOW = 200_000
#: The certificate's offline matrix M (n × (inputs + outputs + terms · order)) is held whole: above this many bytes
#: the model is returned without a bound (info says so).
CERTIFY_BYTES = 2 * 1024 ** 3

Info = dict[str, float | int | str]


def width(engine: CertifyingEngine, system: ThermalSystem, order: int) -> int:
    """Columns of M for a basis of ``order`` vectors: inputs, outputs and every term applied to the basis."""
    terms = len(system.conductance.terms) + len(system.capacity.terms)
    return int(engine.input_terms().shape[1]) + len(system.observation) + terms * order


def stops_on_bound(system: ThermalSystem, certify: bool | None) -> bool:
    """Whether a Krylov greedy stops on the certified bound (``certify``, or by size when None: below
    :data:`CERTIFY_BELOW` unknowns) rather than on its estimate."""
    return system.n < CERTIFY_BELOW if certify is None else certify


def wanted(system: ThermalSystem, certify: bool | None, columns: int, *,
           after_below: int | None = None) -> str | None:
    """None when the model is to be certified (``certify``, or by size when None: below ``after_below`` unknowns,
    default :data:`CERTIFY_AFTER_BELOW`), else why not."""
    if system.time is None:
        return "not computed: a steady model"
    rungs = len(ladder(*_grid(system)))
    limit = CERTIFY_AFTER_BELOW if after_below is None else after_below
    if not (system.n < limit if certify is None else certify):
        return (f"not computed: {system.n} unknowns, it would cost about {rungs} × {columns} "
                "shifted solves (ask with [reduction] certify = true or aromm reduce --certify)")
    if system.n * columns * (8 + 4 * rungs) > CERTIFY_BYTES:  # M, and N̂_σ⁻¹M in float32 per rung (certificate_gram)
        return f"not computed: M of {system.n} × {columns} and its {rungs} solutions would exceed {CERTIFY_BYTES} B"
    return None


def certified(engine: CertifyingEngine, system: ThermalSystem, rom: ReducedModel, psi: FloatArray, *,
              certify: bool | None, reference: Mapping[str, float], training: Sequence[Mapping[str, float]],
              rtol: float, tolerance: float | None = None, certificate: Certificate | None = None,
              after_below: int | None = None, finer: ReducedModel | None = None,
              finer_bounds: Sequence[FloatArray | None] | None = None) -> tuple[ReducedModel, Info]:
    """``rom`` (Galerkin on the basis ``psi`` of the lifted ``system``) with its certificate at the reference values
    (and the ``finer`` certified model it was compressed from, which tightens its bound; ``finer_bounds``: that
    model's bounds at the ``training`` points where the greedy has them, else None: :attr:`SpanBound.finer_bounds`),
    and what its info records: the worst bound over ``training`` (``error_bound``, °C), the CPU seconds, and
    ``converged = 0`` when that bound exceeds ``tolerance`` (issue 35, item 4); without one when :func:`wanted` says
    no (``certificate`` then says why).  A ``certificate`` given (a Krylov build's, formed from its span's Gram
    matrices: :mod:`aromm.reduction.certificate_gram`) is used instead of one computed here; ``after_below``: the
    size below which a model is certified by default (an engine whose wide blocks iterate asks for less)."""
    why = wanted(system, certify, width(engine, system, rom.order), after_below=after_below)
    if why is not None:
        return rom, {"error_bound": float("nan"), "certificate": why}
    start = time.process_time()
    if certificate is None:
        certificate = certificate_of(engine, system, psi, reference, rtol)
    rom = replace(rom, certificate=certificate, finer=finer)
    worst = worst_bound(rom, training, finer_bounds)
    info: Info = {"error_bound": worst, "certificate": "primal-dual contour bound",
                  "certify_seconds": time.process_time() - start}
    if tolerance is not None and worst > tolerance:
        info["converged"] = 0
    return rom, info


def worst_bound(rom: ReducedModel, points: Sequence[Mapping[str, float]],
                finer_bounds: Sequence[FloatArray | None] | None = None) -> float:
    """The largest certified bound (°C) of a certified ``rom`` over outputs and ``points`` (``finer_bounds``: its
    finer model's bounds there, None where not known)."""
    known = finer_bounds if finer_bounds is not None else [None] * len(points)
    bounds = [rom.error_bound(mu, finer_bound=b) for mu, b in zip(points, known, strict=True)]
    return max(float(np.max(b)) for b in bounds if b is not None)


def _grid(system: ThermalSystem) -> tuple[float, float]:
    assert system.time is not None
    return system.time.end, system.time.dt


def tolerance_note(info: Mapping[str, float | int | str]) -> str | None:
    """Why a Krylov model missed its tolerance (``info["converged"]`` 0; by estimate or certified bound), else None."""
    if info.get("method") != "krylov" or int(info.get("converged", 1)) == 1:
        return None
    tol = float(info.get("tolerance", float("nan")))
    loss = float(info.get("compression_loss", 0.0))
    estimate = float(info.get("reference_error", float("nan")))
    bound = float(info.get("error_bound", float("nan")))
    if loss > tol / 2:
        why = f"the compression to order {info.get('order')} lost {loss:.2g} °C (ask for a higher order)"
    elif estimate > tol or not math.isfinite(bound):
        why = (f"the greedy stopped after {info.get('krylov_points')} points with an estimated "
               f"{float(info.get('krylov_estimate', float('nan'))):.2g} °C (raise max_points, or narrow the box)")
    else:
        return (f"the Krylov reduced model did not meet its tolerance {tol:.2g} °C by its certified bound: "
                f"{bound:.2g} °C at worst over its training grid, although its own estimate is {estimate:.2g} °C "
                "(the bound has run 3-65x the actual error; raise max_points or narrow the box to lower it)")
    return (f"the Krylov reduced model did not meet its tolerance {tol:.2g} °C: estimated error "
            f"{estimate:.2g} °C ({why}); an estimate, not a bound")


class SpanBound:
    """The greedy's certified bound (:class:`aromm.reduction.krylov.Bound`) over the training set, from Gram matrices
    kept along the growing span (:class:`~aromm.reduction.certificate_gram.GramLedger`); ``final`` is the compressed
    model's certificate once :meth:`compressed` has been told its coefficients, ``finer`` the span's model it was
    compressed from and ``finer_bounds`` that model's bounds (°C, per output) at the training points the greedy's last
    call evaluated when it was of the final span (None at the others; :func:`certified` does not evaluate them again:
    they cost as much as the greedy's last step)."""

    def __init__(self, engine: CertifyingEngine, system: ThermalSystem, reductor: krylov.KrylovReductor,
                 box: Box) -> None:
        self.engine, self.system, self.reductor = engine, system, reductor
        self.training = training_set(box, reductor.per_axis)
        self.ledger = GramLedger(engine, system, centre(box), reductor.rtol)
        self.final: Certificate | None = None
        self.finer: ReducedModel | None = None
        self.finer_bounds: list[FloatArray | None] | None = None
        self._last: tuple[int, list[FloatArray | None]] | None = None  # (span width, bounds) of the last call
        self._previous = np.full(len(self.training), np.inf)  # each point's latest bound (inf: none yet)

    def _too_large(self, columns: int) -> bool:
        return wanted(self.system, self.reductor.certify, width(self.engine, self.system, columns)) is not None

    def __call__(self, basis: FloatArray, model: ReducedModel) -> FloatArray:
        """The bound at every training point, evaluated lazily: in decreasing order of the previous span's bounds,
        stopping at a point above the tolerance's half whose bound is at least every remaining point's previous one
        (the others keep those: upper estimates where the bound decreases as the span grows, the lazy greedy of
        [Minoux1978]); all of them when none is above (the greedy then stops: every point is certified)."""
        if self._too_large(basis.shape[1]):
            return np.zeros(len(self.training))  # too large to certify: the estimate decides, as without a bound
        self.ledger.extend(basis)
        cert = self.ledger.certificate()
        limit = self.reductor.tolerance / 2
        out = self._previous.copy()
        bounds: list[FloatArray | None] = [None] * len(self.training)
        order = np.argsort(-out, kind="stable")
        for rank, i in enumerate(order):
            bounds[i] = error_bound(model, cert, self.training[i])
            out[i] = float(np.max(bounds[i]))
            later = out[order[rank + 1:]]
            if out[i] > limit and (later.size == 0 or out[i] >= later.max()):
                break
        self._last = (basis.shape[1], bounds)
        self._previous = out
        return out

    def compressed(self, basis: FloatArray, model: ReducedModel, coefficients: FloatArray) -> None:
        if not self._too_large(basis.shape[1]):
            self.ledger.extend(basis)
            self.final = self.ledger.certificate(coefficients)
            if coefficients.shape[1] < coefficients.shape[0]:  # compressed: the span certifies it more tightly
                self.finer = replace(model, info={}, certificate=self.ledger.certificate())
                if self._last is not None and self._last[0] == basis.shape[1]:  # the span last evaluated
                    self.finer_bounds = self._last[1]


def span_bound(engine: CertifyingEngine, system: ThermalSystem, reductor: krylov.KrylovReductor,
               box: Box) -> SpanBound | None:
    """The greedy's certified bound when it is to stop on it (:func:`stops_on_bound`)."""
    if not stops_on_bound(system, reductor.certify) or wanted(system, reductor.certify,
                                                              width(engine, system, 1)) is not None:
        return None
    return SpanBound(engine, system, reductor, box)
