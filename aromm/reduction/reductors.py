"""What a reductor is: a rule that turns the detailed modal model into the coefficients of a reduced basis.

The offline reduction (:mod:`aromm.reduction.offline`) computes a detailed basis Φ of Ñ modes (Dirichlet,
Steklov, constants and correction vectors, :mod:`aromm.reduction.modal_bases`), the detailed modal model on Φ and the
excitation states of reference simulations.  A :class:`Reductor` then chooses coefficients A (Ñ × ñ)
and the reduced basis is Ψ = Φ A; every projected operator becomes ``AᵀXA`` without touching the mesh.
The amalgam [Quemener2012; Chavez2020, eq. 9] (:mod:`aromm.reduction.amalgam`) and POD (:mod:`aromm.reduction.pod`) are
reductors; another one is a class with a ``name`` and a ``coefficients`` method.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.system import FloatArray, TimeGrid
from aromm.reduction.modal_bases import ModalBasis
from aromm.reduction.rom import ReducedModel


@dataclass(frozen=True)
class DetailedModel:
    """What a reductor works from.

    ``basis``: the Ñ detailed modes with their kinds, eigenvalues and capacity Gram matrix Φᵀ C0 Φ;
    ``model``: the detailed modal model (the system projected on Φ, exact in time);
    ``states``: reference excitation states (Ñ × K, one column per reference time, each case normalised).
    """

    basis: ModalBasis
    model: ReducedModel
    states: FloatArray

    @property
    def size(self) -> int:
        return self.basis.size

    def constants(self) -> FloatArray:
        """Unit columns of the constant (mean-temperature) modes, Ñ × n_zero: always kept alone."""
        zero = self.basis.zero_modes
        units = np.zeros((self.size, zero.size))
        units[zero, np.arange(zero.size)] = 1.0
        return units

    def corrections(self, order: int) -> FloatArray:
        """The correction vectors (Ñ × m) to keep as whole columns at this order, or none (Ñ × 0).

        They are kept when the order leaves room for them, the constants and at least one more mode;
        otherwise their directions compete like modes.
        """
        corr = self.basis.corrections if self.basis.corrections is not None else np.zeros((self.size, 0))
        rows = self.modal_rows()
        keep = 0 < corr.shape[1] < order - self.basis.zero_modes.size and order - corr.shape[1] < rows.size
        return corr if keep else np.zeros((self.size, 0))

    def modal_rows(self) -> npt.NDArray[np.int64]:
        """Indices of the Dirichlet–Steklov modes and constants (every row but the correction directions)."""
        return np.flatnonzero(self.basis.kinds != "correction")


@runtime_checkable
class Reductor(Protocol):
    """Coefficients A (Ñ × ñ) of the reduced basis Ψ = Φ A, for ``order`` = ñ < Ñ."""

    @property
    def name(self) -> str: ...

    def coefficients(self, detailed: DetailedModel, order: int) -> FloatArray: ...


def snapshot_times(grid: TimeGrid | None) -> FloatArray:
    """The scene's output grid plus 60 log-spaced times from dt/100 (early boundary layers)."""
    if grid is None:
        raise InputError("the reduced model needs a time grid ([time] section)")
    early = np.geomspace(grid.dt / 100.0, grid.end, 60)
    return np.unique(np.concatenate([early, grid.times]))
