"""The scene and cache pages against the code (issue 23 item 7): every whole TOML example (```toml fences;
fragments of one section are ```{code-block} toml) of docs/guide/scene.md loads
with aromm.load_scene (beside the shipped data it names), the outputs it documents are the ones the parser builds,
and the cache page's table of kinds is aromm.core.cache.KINDS."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from aromm.core.cache import KINDS
from aromm.scene.scene_file import load_scene
from aromm.scene.sensors import output_names

ROOT = Path(__file__).resolve().parents[1]
SCENE_PAGE = ROOT / "docs" / "guide" / "scene.md"
CACHE_PAGE = ROOT / "docs" / "guide" / "cache.md"
EXAMPLES = re.findall(r"```toml\n(.*?)```", SCENE_PAGE.read_text(encoding="utf-8"), flags=re.DOTALL)


def test_the_scene_page_has_examples() -> None:
    assert len(EXAMPLES) >= 2


@pytest.mark.parametrize("index", range(len(EXAMPLES)))
def test_every_toml_example_of_the_scene_page_loads(index: int, tmp_path: Path) -> None:
    """Written where the shipped scenes are (data/scenes/ of a copy: the image ../wood_ver.npz, the histories)."""
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    (tmp_path / "wood_ver.npz").symlink_to(ROOT / "data" / "wood_ver.npz")
    for csv in (ROOT / "data" / "scenes").glob("*.csv"):
        shutil.copy(csv, scenes / csv.name)
    path = scenes / "example.toml"
    path.write_text(EXAMPLES[index], encoding="utf-8")
    scene = load_scene(path)
    for name in re.findall(r"\[outputs\.([A-Za-z0-9_-]+)\]", EXAMPLES[index]):
        assert name in output_names(scene.sensors), (name, scene.sensors)


def test_the_cache_page_lists_the_kinds_of_the_code() -> None:
    text = CACHE_PAGE.read_text(encoding="utf-8")
    rows = re.findall(r"^\| `([a-z-]+)` \| `\1-<key>\.npz` \|", text, flags=re.MULTILINE)
    assert sorted(rows) == sorted(KINDS)
    words = ["no", "one", "two", "three", "four", "five", "six", "seven"]
    assert f"{len(KINDS)} kinds" in text or f"{words[len(KINDS)]} kinds" in text


def test_the_scene_page_no_longer_says_sensors_are_refused() -> None:
    text = SCENE_PAGE.read_text(encoding="utf-8")
    assert "does not accept them" not in text and "`point = [x, y, z]`" in text
