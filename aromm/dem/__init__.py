"""Discrete-element equivalent continuum for heat conduction (seed 000).

packing: dense random sphere packings; bonds: near-neighbour bond lists; network: the
bond network as a ThermalSystem; explicit: forward-Euler integration (seed 000 eq. 5);
calibrate: C_t (eq. 7-8) and effective conductivities; flux: flux densities (eq. 9-10).
"""
