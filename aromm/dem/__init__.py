"""Discrete-element equivalent continuum for heat conduction [Hassan2019].

packing: dense random sphere packings; bonds: near-neighbour bond lists; network: the
bond network as a ThermalSystem; explicit: forward-Euler integration [Hassan2019, eq. 5];
calibration: C_t (eq. 7-8) and effective conductivities; flux: flux densities (eq. 9-10).

Typical use::

    packing = pack_spheres(10_000, np.random.default_rng(0), box=0.1)
    bonds = build_bonds(packing, 7.5)
    c_t = calibrate(packing, 7.5, bonds=bonds).c_t
    cut = packing.cut(packing.lower, packing.lower + packing.box)
    net = Network(cut, build_bonds(cut, gap=bonds.gap_threshold), c_t, np.zeros(cut.n, dtype=int))
    values = {"matrix.k": 33.0, "matrix.c": 7.02e3, "initial.T": 25.0}
    system = net.system(values, boundary=(FaceSpec("y0", T=25.0), FaceSpec("y1", T=100.0)),
                        profile=("y", 20), time=TimeGrid(0.2, 1e-3))
    obs = simulate_explicit(system)            # or aromm.simulate(system): implicit
"""

from aromm.dem.calibration import (
    Calibration,
    InclusionResult,
    calibrate,
    inclusion_network,
    inclusion_ratio,
    inclusion_ratios,
    periodic_conductivity,
    periodic_field,
    slab_conductivity,
)
from aromm.dem.explicit import simulate_explicit, stability_bound, stability_limit
from aromm.dem.flux import neighbourhood_mean, particle_flux
from aromm.dem.neighbours import Bonds, build_bonds, coordination_table, gap_for_coordination
from aromm.dem.network import (
    Network,
    face_particles,
    representative_volumes,
    sphere_inclusion,
    transmission_factor,
)
from aromm.dem.packing import Packing, cubic_lattice, load_packing, pack_spheres

__all__ = [
    "Bonds",
    "Calibration",
    "InclusionResult",
    "Network",
    "Packing",
    "build_bonds",
    "calibrate",
    "coordination_table",
    "cubic_lattice",
    "face_particles",
    "gap_for_coordination",
    "inclusion_network",
    "inclusion_ratio",
    "inclusion_ratios",
    "load_packing",
    "neighbourhood_mean",
    "pack_spheres",
    "particle_flux",
    "periodic_conductivity",
    "periodic_field",
    "representative_volumes",
    "simulate_explicit",
    "slab_conductivity",
    "sphere_inclusion",
    "stability_bound",
    "stability_limit",
    "transmission_factor",
]
