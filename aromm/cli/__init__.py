"""The ``aromm`` command line: JSON on stdout with ``--json``, tables otherwise, progress on stderr.

Exit codes (docs/design.md, :mod:`aromm.cli.common`): 0 success, 1 numerical failure, 2 bad input (message on
stderr), 3 result printed but an optional extra (plot, field) not written, 130 interrupted, 143 terminated
(SIGTERM).  Outputs are checked before the work and never replace an input or a file aromm did not write without
``--force`` (:mod:`aromm.core.files`).
Each group of subcommands lives in its own module, imported when its command runs (:class:`LazyGroup`).
"""

from __future__ import annotations

import importlib
import sys

import click

from aromm.cli.common import run_guarded
from aromm.cli.console import fallback_streams
from aromm.cli.logs import command_logs

#: Each subcommand and the module that defines it: a module is imported when its command runs (or for ``--help``),
#: so ``aromm --version`` and a refused option load none of the numerical wings (tests/test_startup.py).
LOCATIONS = {"bounds": "bounds", "dem": "dem", "simulate": "forward", "homogenize": "forward", "measure": "forward",
             "identify": "identify", "reduce": "reduce", "segment": "scan_commands", "rev": "scan_commands"}


class LazyGroup(click.Group):
    """A click group whose subcommands are imported on first use (:data:`LOCATIONS`)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(LOCATIONS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in LOCATIONS:
            return None
        module = importlib.import_module(f"aromm.cli.{LOCATIONS[cmd_name]}")
        return next(c for c in module.COMMANDS if c.name == cmd_name)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="aromm")
def cli() -> None:
    """Thermal properties of the phases of heterogeneous materials (AROMM)."""


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    from aromm.cli.allocator import tune_allocator

    tune_allocator()
    with fallback_streams(), command_logs():
        return run_guarded(cli, argv if argv is not None else sys.argv[1:])
