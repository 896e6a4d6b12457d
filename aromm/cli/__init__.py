"""The ``aromm`` command line: JSON on stdout with ``--json``, tables otherwise, progress on stderr.

Exit codes (docs/design.md, :mod:`aromm.cli.common`): 0 success, 1 numerical failure, 2 bad input (message on
stderr), 3 result printed but an optional extra (plot, field) not written, 130 interrupted, 143 terminated
(SIGTERM).  Outputs are checked before the work and never replace an input or a file aromm did not write without
``--force`` (:mod:`aromm.core.files`).
Each group of subcommands lives in its own module and is registered below.
"""

from __future__ import annotations

import sys

import click

from aromm.cli import bounds, dem, forward, identify, reduce, scan_commands
from aromm.cli.common import run_guarded
from aromm.cli.console import fallback_streams
from aromm.cli.logs import command_logs

COMMANDS: list[click.Command] = [*forward.COMMANDS, *dem.COMMANDS, *identify.COMMANDS, *reduce.COMMANDS,
                                 *bounds.COMMANDS, *scan_commands.COMMANDS]


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="aromm")
def cli() -> None:
    """Thermal properties of the phases of heterogeneous materials (AROMM)."""


for _command in COMMANDS:
    cli.add_command(_command)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    with fallback_streams(), command_logs():
        return run_guarded(cli, argv if argv is not None else sys.argv[1:])
