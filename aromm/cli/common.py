"""Helpers shared by the subcommands: exit codes, finite numbers, --force, extras, JSON output, progress bars.

Exit codes (:func:`run_guarded`; docs/design.md): 0 success; 1 numerical failure (the message names the solver
and why) or memory exhausted (the message says what to change); 2 bad input (the message names the file, option or
key and what is allowed); 3 the result was printed (and the main output written) but an optional extra (a plot, a
field VTU) could not be written; 130 interrupted (Ctrl-C), with a one-line hint when there is a checkpoint to resume
from; 143 terminated (SIGTERM, unwound as Ctrl-C: cache locks removed).
"""

from __future__ import annotations

import json
import math
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import click
import numpy as np
from tqdm import tqdm

from aromm.core.errors import InputError, NumericalError

if TYPE_CHECKING:  # the scene module loads scipy and the wings: not for `aromm --version`
    from aromm.scene.reduction_section import ReductionSettings
    from aromm.scene.scene_file import Scene

# Peak memory per voxel of the direct (CHOLMOD) path, measured at 80³: 5.5 GB for 5.2e5 nodes (issue 12)
DIRECT_BYTES_PER_VOXEL = 1.1e4

REFINE = click.option("--refine", type=click.IntRange(min=1), default=1, show_default=True,
                      help="Split each voxel into R³ sub-voxel elements (same geometry, finer Q1 discretisation).")

FORCE = click.option("--force", is_flag=True,
                     help="Replace an existing output file that aromm did not write (never one of the inputs).")
SEED = click.IntRange(min=0)  # numpy's generators take non-negative seeds

T = TypeVar("T")

EXIT_NUMERICAL, EXIT_INPUT, EXIT_EXTRA, EXIT_INTERRUPTED, EXIT_TERMINATED = 1, 2, 3, 130, 143


class FiniteFloat(click.FloatRange):
    """A float option that must be finite (click's FloatRange lets ``nan`` through every bound, and ``inf``
    through a lower one), within optional bounds."""

    name = "finite float"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return super().convert(number, param, ctx)


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a command; ``hint`` (one line) says how to continue, e.g. from a checkpoint."""

    def __init__(self, hint: str = "") -> None:
        super().__init__(hint)
        self.hint = hint


class Terminated(KeyboardInterrupt):
    """SIGTERM (what a batch scheduler or ``kill`` sends), raised in the main thread so the command unwinds as for
    Ctrl-C: cache locks and temporary files are removed, one line is printed, the exit code is 143 (128 + 15)."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated()


def refuse_order_with_full_model(model: str) -> None:
    """``--order`` given on the command line with ``--model full`` is refused: it would be ignored (issue 38)."""
    ctx = click.get_current_context()
    if model == "full" and ctx.get_parameter_source("order") is click.core.ParameterSource.COMMANDLINE:
        raise click.UsageError("--order is the reduced model's order: it does not apply to --model full")


#: ``--order`` of the commands that use a reduced model: by default the order of the model built before.
ORDER = click.option("--order", type=click.IntRange(min=1), default=None,
                     help="Reduced-model order ñ (with --model reduced). Default: the order of the model `aromm "
                          "reduce` last built for this scene (same box and options), else 200.")


def reduced_settings(source: Any, settings: ReductionSettings, order: int | None, engine: str) -> ReductionSettings:
    """``settings`` at ``order``; when it is None, at the order of the model last built for ``source`` with these
    settings (:func:`aromm.api.built_order`: ``aromm reduce --order 60`` then ``aromm identify`` use one model), else
    at the settings' own."""
    from aromm.api import built_order

    if order is None:
        order = built_order(source, settings, engine=engine) or settings.order
    return settings.updated(order=order)


class ExtraFailed(Exception):
    """The result was printed, but an optional extra could not be written (exit code 3; message printed)."""


def write_extras(*extras: tuple[str, Callable[[], Path]]) -> None:
    """Write optional outputs (plot, field) after the result was printed; each failure is reported on stderr
    and, once all were tried, ends the command with exit code 3."""
    failed = []
    for what, write in extras:
        try:
            click.echo(f"wrote {write()}", err=True)
        except (InputError, NumericalError, OSError) as err:
            click.echo(f"aromm: error: the {what} was not written: {err}", err=True)
            failed.append(what)
    if failed:
        raise ExtraFailed(", ".join(failed))


def show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,  # noqa: PLR0917
                 file: Any = None, line: str | None = None) -> None:
    """A warning as one line ``aromm: warning: ...`` on stderr (no file name, line number or source line; the
    signature of :func:`warnings.showwarning`); a numerical warning of numpy or scipy says where it came from."""
    origin = "" if issubclass(category, UserWarning) else f" ({category.__name__} in {Path(filename).stem})"
    click.echo(f"aromm: warning: {message}{origin}", err=True)


def run_guarded(cli: click.Group, argv: list[str]) -> int:
    """Run the click group and map what ends it to an exit code (module docstring), with a message; warnings are
    printed as ``aromm: warning:`` lines (:func:`show_warning`), never raw."""
    main = threading.current_thread() is threading.main_thread()  # signal handlers live in the main thread only
    previous = signal.signal(signal.SIGTERM, _terminate) if main else None
    try:
        with warnings.catch_warnings():
            warnings.showwarning = show_warning
            return _run(cli, argv)
    finally:
        if main:
            signal.signal(signal.SIGTERM, previous)


def _run(cli: click.Group, argv: list[str]) -> int:
    try:
        cli.main(args=argv, prog_name="aromm", standalone_mode=False)
    except click.exceptions.Exit as done:
        return int(done.exit_code)
    except click.ClickException as err:
        err.show()
        return EXIT_INPUT
    except click.exceptions.Abort as err:  # click turns KeyboardInterrupt (and EOFError) into Abort
        cause = err.__cause__ or err.__context__  # click < 8.1.4 raised Abort() without "from"
        if isinstance(cause, EOFError):
            click.echo(f"aromm: error: unexpected end of input ({cause})", err=True)
            return EXIT_INPUT
        if isinstance(cause, Terminated):
            click.echo("aromm: terminated (SIGTERM); nothing half-written was kept", err=True)
            return EXIT_TERMINATED
        click.echo("aromm: interrupted", err=True)
        if isinstance(cause, Interrupted) and cause.hint:
            click.echo(f"aromm: {cause.hint}", err=True)
        return EXIT_INTERRUPTED
    except ExtraFailed:
        return EXIT_EXTRA
    except InputError as err:
        click.echo(f"aromm: error: {err}", err=True)
        return EXIT_INPUT
    except NumericalError as err:
        click.echo(f"aromm: numerical failure: {err}", err=True)
        return EXIT_NUMERICAL
    except OSError as err:
        click.echo(f"aromm: error: {err}", err=True)
        return EXIT_INPUT
    except MemoryError:
        click.echo("aromm: out of memory: this problem needs more memory than the machine had free; for a large "
                   "voxel image choose --solver mg (geometric multigrid, memory linear in the voxels), crop or "
                   "down-sample it, or run on the petsc engine", err=True)
        return EXIT_NUMERICAL
    return 0


def refine_scene(scene: Scene, refine: int, bytes_per_voxel: float = DIRECT_BYTES_PER_VOXEL) -> Scene:
    """``scene.refined(refine)``, refused (exit 2) when the refined problem would not fit this machine's memory."""
    return scene.refined(refine, bytes_per_voxel=bytes_per_voxel)


def strict_json(obj: Any) -> Any:
    """``obj`` with numpy arrays and scalars as lists and numbers, and every NaN or infinity as None: JSON has no
    such numbers (Python writes ``NaN``, which jq, JavaScript and most parsers refuse), so a value that is not
    there (a bound not computed, a p-value without data) is ``null``.

    >>> strict_json({"a": float("nan"), "b": [1.0, np.inf], "c": np.array([0.5, np.nan])})
    {'a': None, 'b': [1.0, None], 'c': [0.5, None]}
    """
    if isinstance(obj, dict):
        return {k: strict_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [strict_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return strict_json(obj.tolist())
    if isinstance(obj, np.generic):
        return strict_json(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def echo_json(payload: Any) -> None:
    """Write one strict JSON document on stdout (:func:`strict_json`)."""
    click.echo(json.dumps(strict_json(payload), indent=None, allow_nan=False))


def progress(items: Iterable[T], total: int | None = None, desc: str = "", quiet: bool = False) -> Iterator[T]:
    """A tqdm progress bar on stderr, off when ``quiet`` or when stderr is not a terminal."""
    yield from tqdm(items, total=total, desc=desc, file=sys.stderr, disable=quiet or not sys.stderr.isatty(),
                    leave=False)
