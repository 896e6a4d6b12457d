"""inverse: identification of phase properties from measurements [Chavez2020, § 4].

Usage::

    from inverse import identify, load_measurements
    result = identify(model, load_measurements("y.csv", model.outputs),
                      unknowns={"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}, seed=0)
    result.estimates, result.uncertainty, result.to_json()

The public names are imported on first use (PEP 562), so that importing one light module of the package (its
defaults, the farms) for a command's options does not load the optimisers and scipy.stats (tests/test_startup.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aromm.core import lazy

#: Where each public name lives.
_EXPORTS = {
    "Identification": "inverse.identification", "identify": "inverse.identification",
    "Measurements": "inverse.measurements", "load_measurements": "inverse.measurements",
    "save_measurements": "inverse.measurements", "simulate_measurements": "inverse.measurements",
    "IdentifiabilityWarning": "inverse.uncertainty", "ResidualWarning": "inverse.uncertainty",
    "Uncertainty": "inverse.uncertainty", "UncertaintyWarning": "inverse.uncertainty",
}

if TYPE_CHECKING:
    from inverse.identification import Identification, identify
    from inverse.measurements import Measurements, load_measurements, save_measurements, simulate_measurements
    from inverse.uncertainty import IdentifiabilityWarning, ResidualWarning, Uncertainty, UncertaintyWarning


__getattr__, __dir__ = lazy.exports(__name__, _EXPORTS)


__all__ = [
    "IdentifiabilityWarning",
    "Identification",
    "Measurements",
    "ResidualWarning",
    "Uncertainty",
    "UncertaintyWarning",
    "identify",
    "load_measurements",
    "save_measurements",
    "simulate_measurements",
]
