"""Homogenisation: cell problems, effective conductivity and capacity, the homogeneous twin."""
