"""The documentation says what the code does: the scene-file reference names everything the parser accepts,
the help texts are complete and cite by key, and the stored notebooks carry outputs of the papers' sizes.

Independent truths: the parser's own tables of allowed names (aromm.scene.scene_file, aromm.core.vocabulary, the
generator registry) against the hand-written reference page; click's own description of every option; the metadata
that scripts/regenerate_notebooks.py writes only after a complete run with AROMM_FULL=1.
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import click
import nbformat
import pytest

from aromm.cli import cli
from aromm.core.vocabulary import FACES
from aromm.microstructure.generators import GENERATORS
from aromm.scene.scene_file import FACE_KEYS, PHASE_KEYS, SECTIONS

ROOT = Path(__file__).resolve().parents[1]
SCENE_PAGE = ROOT / "docs" / "guide" / "scene.md"
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def _documented(name: str, text: str) -> bool:
    return f"`{name}`" in text or f"`[{name}" in text or f"[{name}." in text


def test_scene_reference_names_every_section_key_face_and_generator() -> None:
    text = SCENE_PAGE.read_text(encoding="utf-8")
    names = set(SECTIONS) | set(PHASE_KEYS) | set(FACE_KEYS) | set(FACES) | set(GENERATORS)
    for function in GENERATORS.values():  # a generator's keyword options are scene keys
        names |= {p for p in inspect.signature(function).parameters if p != "rng"}
    missing = sorted(n for n in names if not _documented(n, text))
    assert not missing, f"docs/guide/scene.md does not document: {missing}"


def _commands(group: click.Group, prefix: str = "aromm") -> list[tuple[str, click.Command]]:
    """Every command under ``group``, through click's own listing (the top group imports its commands lazily)."""
    out: list[tuple[str, click.Command]] = []
    ctx = click.Context(group)
    for name in sorted(group.list_commands(ctx)):
        command = group.get_command(ctx, name)
        assert command is not None, name
        out.append((f"{prefix} {name}", command))
        if isinstance(command, click.Group):
            out.extend(_commands(command, f"{prefix} {name}"))
    return out


COMMANDS = _commands(cli)


@pytest.mark.parametrize("path,command", COMMANDS, ids=[p for p, _ in COMMANDS])
def test_help_text_is_complete_and_cites_by_key(path: str, command: click.Command) -> None:
    with click.Context(command, info_name=path) as ctx:
        text = command.get_help(ctx)
    assert command.help, f"{path} has no description"
    undocumented = [p.name for p in command.params if isinstance(p, click.Option) and not p.help
                    and p.name not in ("help", "version")]
    assert not undocumented, f"{path}: options without help: {undocumented}"
    assert "%%" not in text  # click does not %-format help texts
    assert not re.search(r"\bseed'?s\b(?! of)|\bthe seed\b|seed[- ]00\d", text, re.IGNORECASE), text


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_stored_notebook_shows_its_results_with_a_figure(path: Path) -> None:
    nb = nbformat.read(path, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code), f"{path.name}: a code cell was not executed"
    outputs = [o for c in code for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any("image/png" in o.get("data", {}) for o in outputs), f"{path.name}: no figure"
    assert "aromm" in nb.metadata, f"{path.name}: not stored by scripts/regenerate_notebooks.py"


# Notebooks whose run at the papers' sizes did not fit the session that wrote them (issue 24, a shared 2-core machine);
# they are stored at the tests' sizes (scripts/regenerate_notebooks.py --small). Once a full run is stored, remove the
# name here and from the warning box of docs/reproductions.md.
STORED_SMALL: set[str] = set()


@pytest.mark.parametrize("path", [
    pytest.param(p, marks=pytest.mark.xfail(strict=True, reason="stored at the tests' sizes, full run pending"))
    if p.stem in STORED_SMALL else p for p in NOTEBOOKS], ids=[p.stem for p in NOTEBOOKS])
def test_stored_notebook_was_computed_at_the_papers_sizes(path: Path) -> None:
    run = nbformat.read(path, as_version=4).metadata.get("aromm", {})
    assert run.get("full") is True, f"{path.name}: not stored from an AROMM_FULL=1 run " \
                                     "(python scripts/regenerate_notebooks.py)"
