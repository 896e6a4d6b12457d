"""The names and defaults the command line and the scene file offer, in a module that imports nothing.

A command's options are declared when its module is imported, which happens before its arguments are checked: the
choices they list must not load the solvers (issue 37, item 4; tests/test_startup.py).  Each name is defined here
once; the modules that act on it import it from here.
"""

from __future__ import annotations

#: Sparse linear solvers of the scipy engine (:mod:`aromm.linalg.direct`).
METHODS = ("auto", "cholmod", "splu", "amg", "mg")
#: Discretisations of a voxel image (:mod:`aromm.scene.model_section`): trilinear elements, finite volumes.
DISCRETISATIONS = ("q1", "fv")
#: Default relative residual of the linear solves (:mod:`aromm.linalg.direct`, ``--rtol``).
DEFAULT_RTOL = 1e-8
#: Eigensolvers of the modal bases (:mod:`aromm.linalg.eigensolvers`; ``"auto"`` by size).
EIGENSOLVERS = ("auto", "arpack", "lobpcg")
#: Boundary conditions of the homogenisation's cell problems (:mod:`aromm.homogenization.cell_problems`).
BOUNDARIES = ("periodic", "flux", "temperature")
#: Default relative spread of k̄ over sub-volumes below which a REV study calls an edge representative (2 %,
#: :mod:`aromm.homogenization.representative`).
REV_TOLERANCE = 0.02
