"""inverse: identification of phase properties from measurements [Chavez2020, § 4].

Usage::

    from inverse import identify, load_measurements
    result = identify(model, load_measurements("y.csv", model.outputs),
                      unknowns={"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}, seed=0)
    result.estimates, result.uncertainty, result.to_json()
"""

from inverse.identification import Identification, identify
from inverse.measurements import (
    Measurements,
    load_measurements,
    save_measurements,
    simulate_measurements,
)
from inverse.uncertainty import IdentifiabilityWarning, ResidualWarning, Uncertainty, UncertaintyWarning

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
