"""Amalgam reduction of a modal basis [Chavez2020, § 3.2, eq. 9; Quemener2012].

The Ñ modes of a detailed basis are distributed into ñ disjoint sub-spaces, each made of one
*principal* mode ``V_{i,0}`` and a few *minor* modes with weights α (eq. 9)::

    Ṽ_i = V_{i,0} + Σ_p α_{i,p} V_{i,p},        Ñ = Σ_i (na_i + 1).

From the excitation states ``x_j(t_k)`` of reference simulations (modes capacity-normalised, so the
weight of a mode is ``E_j = Σ_k x_j(t_k)²``):

1. the ñ modes of largest weight are principal; the constant (zero) modes are forced principal
   and receive no minor mode (they carry the mean temperature: energy balance);
2. every other mode j joins the principal p whose history it best follows up to a factor, i.e.
   the largest uncentred correlation ``|ρ_jp|``, with ``α_{j,p} = ⟨x_j, x_p⟩ / ⟨x_p, x_p⟩``, which
   minimises ``Σ_k (x_j − α x_p)²``;
3. Ψ = Φ A with A (Ñ × ñ) holding 1 for principal modes and α for minor ones.  No mode is
   discarded and the columns of A have disjoint supports.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.reduction.reductors import DetailedModel


@dataclass(frozen=True)
class Amalgam:
    """Coefficients ``A`` (Ñ × ñ) of the amalgamated modes, principal mode and group of every mode."""

    coefficients: FloatArray
    principal: npt.NDArray[np.int64]
    group: npt.NDArray[np.int64]

    @property
    def order(self) -> int:
        return int(self.coefficients.shape[1])


def amalgam(states: FloatArray, order: int, forced: Sequence[int] | npt.NDArray[np.int64] = ()) -> Amalgam:
    """Group the Ñ modes whose reference states are the rows of ``states`` (Ñ × K) into ``order`` modes.

    ``forced`` modes (the constants) are principal and alone in their group.
    """
    states = np.asarray(states, dtype=float)
    n_modes = states.shape[0]
    forced_idx = np.asarray(sorted(set(int(i) for i in forced)), dtype=np.int64)
    if order < forced_idx.size or order < 1:
        raise InputError(f"order must be at least {max(1, forced_idx.size)} (the constant modes), got {order}")
    if order >= n_modes:
        eye = np.eye(n_modes)
        return Amalgam(eye, np.arange(n_modes), np.arange(n_modes))
    energy = np.einsum("ij,ij->i", states, states)
    free = np.setdiff1d(np.arange(n_modes), forced_idx)
    ranked = free[np.argsort(-energy[free], kind="stable")]
    chosen = ranked[: order - forced_idx.size]
    principal = np.concatenate([forced_idx, np.sort(chosen)])
    minor = np.setdiff1d(free, chosen)
    group = np.empty(n_modes, dtype=np.int64)
    group[principal] = np.arange(principal.size)
    coefficients = np.zeros((n_modes, principal.size))
    coefficients[principal, np.arange(principal.size)] = 1.0
    heads = np.sort(chosen)
    if minor.size and heads.size:
        xp = states[heads]  # (h, K)
        pp = np.einsum("ij,ij->i", xp, xp)
        norms_p = np.sqrt(pp)
        cross = states[minor] @ xp.T  # (minor, h)
        norms_i = np.sqrt(energy[minor])
        rho = np.abs(cross) / np.maximum(norms_i[:, None] * norms_p[None, :], 1e-300)
        best = np.argmax(rho, axis=1)
        alpha = cross[np.arange(minor.size), best] / np.maximum(pp[best], 1e-300)
        cols = forced_idx.size + best
        coefficients[minor, cols] = alpha
        group[minor] = cols
    elif minor.size:
        group[minor] = -1  # only constants are principal: minor modes are dropped
    return Amalgam(coefficients, principal, group)


@dataclass(frozen=True)
class AmalgamReductor:
    """The AROMM reductor [Chavez2020, eq. 9]: the amalgam of the detailed modes on the reference states.

    The constants are forced principal and alone; when the order leaves room, the correction vectors are
    kept as whole columns and the amalgam groups the Dirichlet–Steklov modes into the remaining columns.
    """

    name: str = "aromm"

    def coefficients(self, detailed: DetailedModel, order: int) -> FloatArray:
        zero = detailed.basis.zero_modes
        corr = detailed.corrections(order)
        if not corr.shape[1]:
            return amalgam(detailed.states, order, zero).coefficients
        rows = detailed.modal_rows()
        sub = amalgam(detailed.states[rows], order - corr.shape[1], np.searchsorted(rows, zero)).coefficients
        a = np.zeros((detailed.size, order))
        a[rows, : sub.shape[1]] = sub
        a[:, sub.shape[1]:] = corr
        return a
