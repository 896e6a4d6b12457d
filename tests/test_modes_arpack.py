"""ARPACK failures of the modal bases surface as NumericalError naming the solver, never as a raw ArpackError.

Independent truth: ARPACK's own refusal (error -9999, no Arnoldi factorisation) when many Steklov modes of a
homogeneous cube are asked for (a singular boundary mass, 602 boundary nodes, 350 modes; found while reproducing
[Chavez2020, Figs. 2-3]).
"""

from __future__ import annotations

import numpy as np
import pytest

from aromm.core.errors import NumericalError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import PhaseSpec
from aromm.fem import assemble_voxels
from aromm.reduction.modal_bases import reference_operators, steklov_modes


def test_arpack_refusal_is_a_numerical_error_that_names_the_remedy() -> None:
    n = 11  # 1728 nodes: above the dense limit, so ARPACK shift-invert is used
    system = assemble_voxels(np.zeros((n, n, n), dtype=int), (1.0 / n,) * 3, [PhaseSpec("solid", 0, 1.0, 1.0)],
                             time=TimeGrid(1.0, 0.1))
    with pytest.raises(NumericalError, match=r"ARPACK shift-invert.*lobpcg"):
        steklov_modes(reference_operators(system), 350, eigensolver="arpack")
