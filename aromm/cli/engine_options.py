"""``--engine scipy|petsc`` on the commands that assemble and solve (simulate, homogenize, reduce, measure,
identify).

With ``--engine petsc`` the command runs under ``mpiexec -n P`` (PETSc/SLEPc, aromm.engines.petsc): every
rank executes it, reads its box of the image (:func:`aromm.engines.petsc.problem.load_problem`), and
only rank 0 prints and writes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aromm.api import is_root
from aromm.cli.common import DIRECT_BYTES_PER_VOXEL, refine_scene
from aromm.core.errors import InputError
from aromm.engines import ENGINES, PETSC_SOLVERS, check_engine, check_solver
from aromm.linalg.direct import METHODS
from aromm.scene.scene_file import Scene, load_scene

ENGINE = click.option("--engine", type=click.Choice(ENGINES), default="scipy", show_default=True,
                      help="scipy: one process; petsc: PETSc/SLEPc under `mpiexec -n P` (rank 0 prints and writes).")
SOLVER = click.option("--solver", type=click.Choice((*METHODS, *PETSC_SOLVERS)), default="auto", show_default=True,
                      help="Sparse linear solver. scipy engine: cholmod (cvxopt's supernodal Cholesky), splu, amg "
                           "(pyamg + CG), mg (CG + geometric multigrid on the voxel grid); auto: mg for a steady "
                           "solve of a voxel image from 4,000 unknowns (homogenize: from 20³ voxels), else "
                           "cholmod; petsc engine: gamg (CG + algebraic multigrid), mumps (Cholesky).")


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

        return load_problem(path, runtime.world())
    return refine_scene(load_scene(path), refine, bytes_per_voxel)


def outline(source: Any) -> Scene:
    """The Scene that the checks of a command read (phases, faces, time grid, outputs, box): the scene itself on
    the scipy engine, the petsc problem's outline (no image held: :meth:`VoxelProblem.outline`) on petsc."""
    return source if isinstance(source, Scene) else source.outline()


def echo(engine: str, text: str = "") -> None:
    """``click.echo`` on the process that prints (rank 0 under the petsc engine)."""
    if is_root(engine):
        click.echo(text)
