"""``--engine scipy|petsc`` on the commands that assemble and solve (simulate, homogenize, reduce, measure,
identify), and ``--discretisation q1|fv`` on those and ``rev`` (it replaces the scene's ``[model] discretisation``).

With ``--engine petsc`` the command runs under ``mpiexec -n P`` (PETSc/SLEPc, aromm.engines.petsc): every
rank executes it, reads its box of the image (:func:`aromm.engines.petsc.problem.load_problem`), and
only rank 0 prints and writes.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from aromm.cli.common import DIRECT_BYTES_PER_VOXEL, refine_scene
from aromm.core.choices import DISCRETISATIONS, METHODS
from aromm.core.errors import InputError
from aromm.engines import ENGINES, PETSC_SOLVERS, check_engine, check_solver, is_root

if TYPE_CHECKING:
    from aromm.scene.scene_file import Scene

ENGINE = click.option("--engine", type=click.Choice(ENGINES), default="scipy", show_default=True,
                      help="scipy: one process; petsc: PETSc/SLEPc under `mpiexec -n P` (rank 0 prints and writes).")
SOLVER = click.option("--solver", type=click.Choice((*METHODS, *PETSC_SOLVERS)), default="auto", show_default=True,
                      help="Sparse linear solver. scipy engine: cholmod (cvxopt's supernodal Cholesky), splu, amg "
                           "(pyamg + CG), mg (CG + geometric multigrid on the voxel grid; with --discretisation fv "
                           "the matrix-free aggregation multigrid for the temperature and flux probes, pyamg + CG "
                           "for periodic cells); auto: mg for a steady solve of a voxel image from 4,000 unknowns "
                           "(homogenize: from 20³ voxels), else cholmod; petsc engine: gamg (CG + algebraic "
                           "multigrid), mumps (Cholesky).")



def _remember(ctx: click.Context, _param: click.Parameter, value: str | None) -> str | None:
    ctx.meta["aromm.discretisation"] = value
    return value


DISCRETISATION = click.option(
    "--discretisation", type=click.Choice(DISCRETISATIONS), default=None, expose_value=False, callback=_remember,
    help="q1: trilinear elements (the papers' method); fv: cell-centred finite volumes with harmonic-mean face "
         "conductances (taufactor, PuMA), which allow k = 0. Default: the scene's [model] discretisation, else q1.")


def discretisation() -> str | None:
    """The ``--discretisation`` of the running command (None: the scene's own)."""
    ctx = click.get_current_context(silent=True)
    return ctx.meta.get("aromm.discretisation") if ctx is not None else None


def resolve(engine: str, solver: str) -> str:
    """Checks the engine (installed?) and that the solver belongs to it; returns the solver."""
    return check_solver(check_engine(engine), solver, METHODS)


def load(path: Path, engine: str, refine: int = 1, bytes_per_voxel: float = DIRECT_BYTES_PER_VOXEL) -> Any:
    """The scene for ``engine``: a Scene (refined ``refine`` times, memory checked at ``bytes_per_voxel``), or for
    petsc a VoxelProblem whose image each rank reads by boxes."""
    if engine == "petsc":
        if refine != 1:
            raise InputError("--refine works with the scipy engine; with --engine petsc refine the image file")
        from aromm.engines.petsc import runtime
        from aromm.engines.petsc.problem import load_problem

        return load_problem(path, runtime.world(), discretisation())
    from aromm.scene.scene_file import load_scene

    return refine_scene(load_scene(path, discretisation()), refine, bytes_per_voxel)


def outline(source: Any) -> Scene:
    """The Scene that the checks of a command read (phases, faces, time grid, outputs, box): the scene itself on
    the scipy engine, the petsc problem's outline (no image held: :meth:`VoxelProblem.outline`) on petsc."""
    from aromm.scene.scene_file import Scene

    return source if isinstance(source, Scene) else source.outline()


def echo(engine: str, text: str = "") -> None:
    """``click.echo`` on the process that prints (rank 0 under the petsc engine)."""
    if is_root(engine):
        click.echo(text)
