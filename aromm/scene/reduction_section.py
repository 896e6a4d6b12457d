"""How a reduced model is built: :class:`ReductionSettings`, and the ``[reduction]`` section of a scene file.

One frozen object holds every knob of ``aromm.reduce`` [Chavez2020, § 3]: the order, the method
(:data:`REDUCTION_METHODS`, ``"auto"`` by size), the detailed modal basis (Ñ and its split), the reference
properties of the bases and of the reference simulation (``basis`` and ``reference``, overrides of the scene's
parameters), the relaxation case and correction vectors, the identification box of the Krylov reduction
(``bounds``) and its greedy's tolerance (``tolerance``, °C), and the solvers.  A scene's ``[reduction]`` section sets
``basis``, ``reference``, ``method``, ``bounds`` and ``tolerance``; the command line replaces the rest
(:meth:`ReductionSettings.updated`); the reduction reads the object, and its cache key is made of
:meth:`ReductionSettings.key`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from numbers import Integral
from typing import Any

from aromm.core.choices import EIGENSOLVERS
from aromm.core.errors import InputError
from aromm.scene.toml import TableReader

#: The reduction methods by name: ``"auto"`` (by size, :data:`KRYLOV_ABOVE`), the reductors of
#: aromm.reduction.offline's REDUCTORS (amalgam, POD, POD-greedy) and ``"krylov"`` (aromm.reduction.krylov).
REDUCTION_METHODS = ("auto", "aromm", "pod", "greedy", "krylov")
#: ``method="auto"`` builds the eigen-free Krylov model for systems with more free unknowns than this, the amalgam of
#: modes [Chavez2020, § 3] below.  Measured crossover (docs/method/krylov.md, "Choice by size";
#: benchmarks/method_crossover.py, 2026-12-02): the amalgam's build costs 2.0× less CPU at 24³ voxels (1.6e4
#: unknowns), the Krylov build 0.80× the amalgam's at 32³ (3.6e4) and 0.60× at 40³ (6.9e4): the switch sits between
#: 24³ and 32³, at about 31³.
KRYLOV_ABOVE = 30_000
#: Keyword names ``aromm.reduce`` has always accepted for two fields.
ALIASES = {"basis_values": "basis", "reference_values": "reference"}
#: Options that only the modal methods use (the Krylov reduction refuses them; ``"auto"`` then picks the amalgam).
#: ``reference`` is modal too, but a scene states it for its amalgam: the Krylov reduction leaves it aside.
MODAL_OPTIONS = ("modes", "n_dirichlet", "n_steklov", "relaxation", "corrections", "eigensolver", "basis_storage")
BASIS_STORAGES = ("float64", "float32")


@dataclass(frozen=True)
class ReductionSettings:
    """Every option of a reduced model's build (module docstring; ``aromm.reduction.offline.reduce`` says what each
    does).

    ``order`` ñ; ``method``: a name of :data:`REDUCTION_METHODS` or a reductor object; ``modes`` Ñ (default
    1.5 ñ + 20), ``n_dirichlet`` / ``n_steklov`` its split; ``basis`` / ``reference``: parameter overrides (name →
    value, SI) of the modal bases and of the reference simulation; ``relaxation``: the cooling reference case;
    ``corrections``: True, False or the parameter samples of the correction vectors; ``bounds``: name → (lower,
    upper), the identification box, over which the Krylov reduction trains (a certified modal model is certified over
    it through a Krylov referee, aromm.reduction.referee);
    ``tolerance`` (°C): the Krylov reduction's greedy stops at this estimated error (None: the reductor's default,
    aromm.reduction.krylov.KrylovReductor; a Krylov-only option, so ``"auto"`` then picks the Krylov method);
    ``certify``: attach the certified output error bound and stop the Krylov greedy on it (None: by size, by its cost:
    certified below 200,000 unknowns, the greedy stops on it below 40,000; every one-process method,
    aromm.reduction.certified);
    ``solver`` (linear solves), ``eigensolver`` and ``basis_storage`` of the modal bases."""

    order: int = 200
    method: Any = "auto"
    modes: int | None = None
    n_dirichlet: int | None = None
    n_steklov: int | None = None
    basis: Mapping[str, float] = field(default_factory=dict)
    reference: Mapping[str, float] = field(default_factory=dict)
    relaxation: bool = True
    corrections: bool | Sequence[Mapping[str, float]] = True
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    tolerance: float | None = None
    certify: bool | None = None
    solver: str = "auto"
    eigensolver: str = "auto"
    basis_storage: str = "float64"

    def updated(self, **changes: Any) -> ReductionSettings:
        """A copy with ``changes`` (field names, or ``basis_values`` / ``reference_values``); None leaves a field
        as it is; an unknown name is refused with the allowed ones."""
        names = {f.name for f in fields(self)}
        given = {ALIASES.get(k, k): v for k, v in changes.items() if v is not None}
        unknown = sorted(set(given) - names)
        if unknown:
            raise InputError(f"reduce: unknown option(s) {unknown}; allowed: {', '.join(sorted(names | set(ALIASES)))}")
        return replace(self, **given).checked()

    def checked(self) -> ReductionSettings:
        """Self, after checking the values that need no system (InputError naming the option otherwise)."""
        for name in ("order", "modes", "n_dirichlet", "n_steklov"):
            value, lowest = getattr(self, name), 1 if name in ("order", "modes") else 0
            if value is not None and (isinstance(value, bool) or not isinstance(value, Integral) or value < lowest):
                raise InputError(f"{name} must be an integer >= {lowest}, got {value!r}")
        if isinstance(self.method, str) and self.method not in REDUCTION_METHODS:
            raise InputError(f"unknown reduction method {self.method!r}; allowed: {', '.join(REDUCTION_METHODS)}")
        modal = self.modal_options()
        if self.method == "krylov" and modal:
            raise InputError(f"reduce: {', '.join(modal)} belong to the modal methods (aromm, pod, greedy), not to "
                             "method 'krylov' (its options are those of aromm.reduction.krylov.KrylovReductor)")
        if self.tolerance is not None and not (isinstance(self.tolerance, int | float)
                                               and math.isfinite(self.tolerance) and self.tolerance > 0):
            raise InputError(f"tolerance (°C, of the Krylov reduction's greedy) must be a finite number > 0, got "
                             f"{self.tolerance!r}")
        if self.certify not in (None, True, False):
            raise InputError(f"certify must be true, false or left out (by size), got {self.certify!r}")
        if self.tolerance is not None and (self.method in ("aromm", "pod", "greedy")
                                           or (self.method == "auto" and modal)):
            raise InputError("reduce: tolerance belongs to method 'krylov', not to "
                             f"{'the modal options ' + ', '.join(modal) if modal else repr(self.method)}")
        if self.eigensolver not in EIGENSOLVERS:
            raise InputError(f"unknown eigensolver {self.eigensolver!r}; allowed: {', '.join(EIGENSOLVERS)}")
        if self.basis_storage not in BASIS_STORAGES:
            raise InputError(f"basis_storage must be one of {', '.join(BASIS_STORAGES)}, got {self.basis_storage!r}")
        return self

    def modal_options(self) -> list[str]:
        """The options given that only the modal methods (amalgam, POD, greedy) use."""
        defaults = ReductionSettings()
        return [name for name in MODAL_OPTIONS if getattr(self, name) != getattr(defaults, name)]

    def method_for(self, unknowns: int, references: bool = False) -> Any:
        """The method for a system of ``unknowns`` free unknowns: ``"auto"`` is the amalgam when a modal option
        (:data:`MODAL_OPTIONS`) or reference cases (``references``) are given, else resolved by
        :data:`KRYLOV_ABOVE`."""
        if self.method != "auto":
            return self.method
        if self.tolerance is not None:
            return "krylov"
        if self.modal_options() or references:
            return "aromm"
        return "krylov" if unknowns > KRYLOV_ABOVE else "aromm"

    def samples(self, default: Sequence[Mapping[str, float]]) -> list[dict[str, float]]:
        """The correction samples: ``default`` (True), none (False) or the given ones."""
        chosen = default if self.corrections is True else () if self.corrections is False else self.corrections
        return [dict(s) for s in chosen]

    def key(self) -> tuple[Any, ...]:
        """The options that change a model built from them, in a canonical form (part of the cache key)."""
        method = self.method if isinstance(self.method, str) else getattr(self.method, "cache_key", self.method.name)
        return (self.order, method, self.modes, self.n_dirichlet, self.n_steklov, dict(self.basis),
                dict(self.reference), self.relaxation, self.samples(()) if self.corrections is not True else True,
                {k: tuple(v) for k, v in self.bounds.items()}, self.solver, self.eigensolver, self.basis_storage,
                self.tolerance, self.certify)


def parse_reduction(r: TableReader, data: Mapping[str, Any], parameters: Mapping[str, float]) -> ReductionSettings:
    """``[reduction]`` with ``basis`` and ``reference`` tables of parameter overrides (positive numbers), a
    ``method`` name, ``bounds`` (parameter → [lower, upper], 0 < lower <= upper), the Krylov ``tolerance`` (°C) and
    ``certify`` (true or false)."""
    table = r.table(data, "reduction", ("basis", "reference", "method", "bounds", "tolerance", "certify"))
    out: dict[str, dict[str, float]] = {}
    for part in ("basis", "reference"):
        given = r.table(table, f"reduction.{part}", None, part)
        unknown = sorted(set(given) - set(parameters))
        if unknown:
            raise r.fail(f"reduction.{part}", f"unknown parameter(s) {unknown}; the scene has "
                                              f"{', '.join(sorted(parameters))}")
        out[part] = {k: r.number(v, f"reduction.{part}.{k}", positive=True) for k, v in given.items()}
    method = table.get("method", "auto")
    if method not in REDUCTION_METHODS:
        raise r.fail("reduction.method", f"must be one of {', '.join(REDUCTION_METHODS)}, got {method!r}")
    bounds: dict[str, tuple[float, float]] = {}
    for name, pair in r.table(table, "reduction.bounds", None, "bounds").items():
        key = f"reduction.bounds.{name}"
        if name not in parameters:
            raise r.fail(key, f"unknown parameter; the scene has {', '.join(sorted(parameters))}")
        if not isinstance(pair, list) or len(pair) != 2:
            raise r.fail(key, f"must be [lower, upper], got {pair!r}")
        lo, hi = (r.number(v, key, positive=True) for v in pair)
        if lo > hi:
            raise r.fail(key, f"lower bound {lo:g} above the upper bound {hi:g}")
        bounds[name] = (lo, hi)
    tolerance = r.number(table["tolerance"], "reduction.tolerance", positive=True) if "tolerance" in table else None
    certify = table.get("certify")
    if certify is not None and not isinstance(certify, bool):
        raise r.fail("reduction.certify", f"must be true or false, got {certify!r}")
    return ReductionSettings(basis=out["basis"], reference=out["reference"], method=method, bounds=bounds,
                             tolerance=tolerance, certify=certify)
