"""Helpers shared by the subcommands: error mapping, JSON output, progress bars."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterable, Iterator
from typing import Any, TypeVar

import click
import numpy as np
from tqdm import tqdm

from aromm.errors import InputError, NumericalError
from aromm.scene import Scene

# Peak memory per voxel of the direct (CHOLMOD) path, measured at 80³: 5.5 GB for 5.2e5 nodes (issue 12)
DIRECT_BYTES_PER_VOXEL = 1.1e4

REFINE = click.option("--refine", type=click.IntRange(min=1), default=1, show_default=True,
                      help="Split each voxel into R³ sub-voxel elements (same geometry, finer Q1 discretisation).")

T = TypeVar("T")


def run_guarded(cli: click.Group, argv: list[str]) -> int:
    """Run the click group; bad input -> exit 2, numerical failure -> exit 1, both with a message."""
    try:
        cli.main(args=argv, prog_name="aromm", standalone_mode=False)
    except click.exceptions.Exit as done:
        return int(done.exit_code)
    except click.ClickException as err:
        err.show()
        return 2
    except click.exceptions.Abort:
        click.echo("aborted", err=True)
        return 1
    except InputError as err:
        click.echo(f"aromm: error: {err}", err=True)
        return 2
    except NumericalError as err:
        click.echo(f"aromm: numerical failure: {err}", err=True)
        return 1
    except OSError as err:
        click.echo(f"aromm: error: {err}", err=True)
        return 2
    return 0


def refine_scene(scene: Scene, refine: int, bytes_per_voxel: float = DIRECT_BYTES_PER_VOXEL) -> Scene:
    """``scene.refined(refine)``, refused (exit 2) when the refined problem would not fit this machine's memory."""
    return scene.refined(refine, bytes_per_voxel=bytes_per_voxel)


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def echo_json(payload: Any) -> None:
    """Write one JSON document on stdout (numpy arrays and scalars converted)."""
    click.echo(json.dumps(payload, default=_default, indent=None))


def progress(items: Iterable[T], total: int | None = None, desc: str = "", quiet: bool = False) -> Iterator[T]:
    """A tqdm progress bar on stderr, off when ``quiet`` or when stderr is not a terminal."""
    yield from tqdm(items, total=total, desc=desc, file=sys.stderr, disable=quiet or not sys.stderr.isatty(),
                    leave=False)
