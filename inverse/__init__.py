"""inverse: identification of phase properties from measurements [Chavez2020, § 4].

    from inverse import identify, load_measurements
    result = identify(model, load_measurements("y.csv", model.outputs),
                      unknowns={"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}, seed=0)
    result.estimates, result.uncertainty, result.to_json()
"""

from inverse.identification import Identification, identify
from inverse.measurements import (
    Measurements,
    homogeneous_measurements,
    load_measurements,
    save_measurements,
    simulate_measurements,
)
from inverse.uncertainty import IdentifiabilityWarning, Uncertainty

__all__ = [
    "IdentifiabilityWarning",
    "Identification",
    "Measurements",
    "Uncertainty",
    "homogeneous_measurements",
    "identify",
    "load_measurements",
    "save_measurements",
    "simulate_measurements",
]
