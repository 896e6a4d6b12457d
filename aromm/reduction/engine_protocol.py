"""What the offline reduction needs from a computational engine: the engine protocol.

An engine owns the full model of one :class:`~aromm.core.system.ThermalSystem` (its fixed temperatures already
lifted, :mod:`aromm.reduction.lifting`) and its large vectors.  The reductors written against this protocol
(:mod:`aromm.reduction.krylov`) handle only *blocks* — opaque n × m collections of vectors that live inside the engine
(NumPy arrays for the scipy engine, :mod:`aromm.reduction.scipy_engine`; distributed dense matrices for an MPI
engine) — and small dense NumPy arrays (reduced operators, Gram matrices, coefficients), which every process
holds whole.  So the same reduction runs on one process or under MPI once an engine implements:

* the inputs of the system: every load term ``F_j``, and the initial fields ``C(μ) T0`` (:meth:`input_terms`,
  :meth:`input_coefficients`, :meth:`inputs`), and the observation rows ``Eᵀ`` (:meth:`output_block`);
* a shifted SPD solve ``(K(μ) + s C(μ)) X = B`` of a block to a relative residual (:meth:`shifted_solve`), and
  the capacity ``C(μ) X`` (:meth:`capacity`);
* C(μ)-orthonormalisation of a block against a basis (:meth:`orthonormalise`) and linear combinations
  (:meth:`combine`);
* the Galerkin projection of every affine term onto a basis (:meth:`project`: the ordinary
  :class:`~aromm.reduction.rom.ReducedModel`) and the residuals of reduced frequency responses (:meth:`residual_norms`).

Units are SI (K, C in J/K and W/K per unknown; shifts s in 1/s).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from aromm.core.system import FloatArray
from aromm.reduction.rom import ReducedModel

#: An engine's block of n-vectors (n × m); only the engine that made it looks inside.
Block = Any


@dataclass
class SolveStats:
    """What the shifted solves cost: set-ups (factorisations or multigrid hierarchies), solves (one per
    right-hand side), iterations of the iterative solves (empty for direct ones), CPU seconds."""

    setups: int = 0
    solves: int = 0
    iterations: list[int] = field(default_factory=list)
    setup_seconds: float = 0.0
    solve_seconds: float = 0.0
    method: str = ""


class ReductionEngine(Protocol):
    """The operations of the offline reduction on the full model (module docstring)."""

    @property
    def size(self) -> int:
        """Number of (free) unknowns n."""
        ...

    @property
    def stats(self) -> SolveStats:
        """Running totals of the shifted solves."""
        ...

    def input_terms(self) -> Block:
        """The fixed vectors U (n × p) the inputs are made of: load terms, capacity terms times initial fields."""
        ...

    def input_coefficients(self, values: Mapping[str, float]) -> FloatArray:
        """A(μ) (p × q): the inputs at μ are the columns of ``U A(μ)``."""
        ...

    def input_weights(self, values: Mapping[str, float]) -> FloatArray:
        """The scalar factor of each of the q inputs at μ in the system's equation (a load term's coefficient,
        the initial temperature): an input whose weight vanishes over the whole box is never excited."""
        ...

    def inputs(self, values: Mapping[str, float]) -> Block:
        """The q inputs at μ, ``U A(μ)`` (n × q)."""
        ...

    def constant(self) -> Block:
        """The uniform field 1 (n × 1), the direction of the mean temperature (kept in every basis)."""
        ...

    def output_block(self) -> Block:
        """Eᵀ (n × n_outputs): the observation rows as columns (the dual inputs)."""
        ...

    def width(self, block: Block) -> int:
        """Number of columns of a block."""
        ...

    def shifted_solve(self, values: Mapping[str, float], shift: float, rhs: Block, rtol: float,
                      guess: Block | None = None) -> Block:
        """X with ``‖(K(μ) + s C(μ)) x_j − b_j‖ ≤ rtol ‖b_j‖`` for every column; NumericalError otherwise.
        ``guess``: initial iterates of an iterative solver (a direct one ignores it)."""
        ...

    @property
    def uses_guess(self) -> bool:
        """Whether :meth:`shifted_solve` starts from ``guess`` (an iterative solver): else none is formed."""
        ...

    def capacity(self, values: Mapping[str, float], block: Block) -> Block:
        """C(μ) X."""
        ...

    def orthonormalise(self, basis: Block | None, block: Block, values: Mapping[str, float],
                       drop: float) -> tuple[Block, int]:
        """The basis with the C(μ)-orthonormal directions of ``block`` not yet in its span appended (columns
        whose part outside the span is below ``drop`` times their C-norm are left out), and how many came in."""
        ...

    def dot(self, left: Block, right: Block) -> FloatArray:
        """``leftᵀ right`` (Euclidean), a small dense matrix on every process."""
        ...

    def join(self, blocks: Sequence[Block]) -> Block:
        """The columns of ``blocks`` side by side, in order."""
        ...

    def combine(self, basis: Block, coefficients: FloatArray, consume: bool = False) -> Block:
        """``basis @ coefficients`` (coefficients dense r × r'); with ``consume`` the caller never uses ``basis``
        again and the engine may write the result over it (the final compression of a large basis)."""
        ...

    def project(self, basis: Block) -> ReducedModel:
        """The Galerkin reduced model on the columns of ``basis`` (every affine term projected)."""
        ...

    def reduced_operator(self, basis: Block, values: Mapping[str, float], shift: float) -> FloatArray:
        """``Vᵀ (K(μ) + s C(μ)) V`` (r × r) on the columns of ``basis``: the pencil only, none of the inputs,
        outputs and initial terms of :meth:`project`."""
        ...

    def residual_norms(self, basis: Block, values: Mapping[str, float], shifts: FloatArray,
                       solutions: FloatArray) -> FloatArray:
        """``‖b_i(μ) − (K(μ) + s_k C(μ)) V x_ki‖`` (S × q) for reduced solutions ``solutions`` (S × r × q), with
        b_i(μ) the inputs at μ (columns of :meth:`inputs`): the residuals of reduced frequency responses."""
        ...

    def to_numpy(self, block: Block) -> FloatArray:
        """The block as an n × m NumPy array on this process (for fields; an MPI engine gathers it)."""
        ...
