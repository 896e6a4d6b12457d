"""The ``[reduction]`` section of a scene file: how its reduced model is built [Chavez2020, § 3].

``basis`` and ``reference`` are overrides of the scene's parameters for the modal bases and the reference
simulation; ``method`` names the reduction (:data:`REDUCTION_METHODS`); ``bounds`` is the identification box of
the Krylov reduction.  :meth:`ReductionSettings.options` turns the section into keyword arguments of
``aromm.reduce``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from aromm.scene.toml import TableReader

#: The reduction methods a scene may name (aromm.reduction.offline implements each: the reductors of its
#: REDUCTORS, and "krylov", aromm.reduction.krylov).
REDUCTION_METHODS = ("aromm", "pod", "greedy", "krylov")


@dataclass(frozen=True)
class ReductionSettings:
    """``[reduction]``: reference properties of the modal bases (``basis``) and of the reference simulation
    (``reference``), as overrides of the scene's parameters (e.g. ``{"fibre.k": 0.53}``; [Chavez2020, § 3]);
    the reduction ``method`` (:data:`REDUCTION_METHODS`) and, for ``"krylov"``, the identification box ``bounds``
    (name → (lower, upper))."""

    basis: Mapping[str, float] = field(default_factory=dict)
    reference: Mapping[str, float] = field(default_factory=dict)
    method: str = "aromm"
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    def options(self, method: str | None = None) -> dict[str, Any]:
        """Keyword arguments of ``aromm.reduce``: the method (``method`` overrides the scene's), its box."""
        chosen = method or self.method
        return {"method": chosen, **({"bounds": dict(self.bounds)} if chosen == "krylov" and self.bounds else {}),
                "basis_values": self.basis, "reference_values": self.reference}


def parse_reduction(r: TableReader, data: Mapping[str, Any], parameters: Mapping[str, float]) -> ReductionSettings:
    """``[reduction]`` with ``basis`` and ``reference`` tables of parameter overrides (positive numbers), a
    ``method`` name and ``bounds`` (parameter → [lower, upper], 0 < lower <= upper)."""
    table = r.table(data, "reduction", ("basis", "reference", "method", "bounds"))
    out: dict[str, dict[str, float]] = {}
    for part in ("basis", "reference"):
        given = r.table(table, f"reduction.{part}", None, part)
        unknown = sorted(set(given) - set(parameters))
        if unknown:
            raise r.fail(f"reduction.{part}", f"unknown parameter(s) {unknown}; the scene has "
                                              f"{', '.join(sorted(parameters))}")
        out[part] = {k: r.number(v, f"reduction.{part}.{k}", positive=True) for k, v in given.items()}
    method = table.get("method", "aromm")
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
    return ReductionSettings(out["basis"], out["reference"], method, bounds)
