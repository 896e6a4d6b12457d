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
    words = ["no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine"]
    assert f"{len(KINDS)} kinds" in text or f"{words[len(KINDS)]} kinds" in text


def test_the_scene_page_no_longer_says_sensors_are_refused() -> None:
    text = SCENE_PAGE.read_text(encoding="utf-8")
    assert "does not accept them" not in text and "`point = [x, y, z]`" in text


#: The first-run record of benchmarks/first_run.py (the README's main job, cold, on the machine it names).
FIRST_RUN = ROOT / "benchmarks" / "records" / "first_run.json"
FIRST_RUN_PAGES = (ROOT / "README.md", ROOT / "docs" / "getting_started.md", CACHE_PAGE)


@pytest.mark.parametrize("page", FIRST_RUN_PAGES, ids=lambda p: p.name)
def test_the_first_run_figures_of_a_page_are_the_records(page: Path) -> None:
    """Issue 38 item 5: a page that quotes the first identify's cost ("about N s of CPU", "X GB") or its model's
    order quotes benchmarks/records/first_run.json, to the rounding of prose (CPU within 20 %, memory within
    0.1 GB: a re-run on the same machine moves them by a few per cent); the method is the record's."""
    import json

    record = json.loads(FIRST_RUN.read_text(encoding="utf-8"))
    text = page.read_text(encoding="utf-8")
    cpu = [float(x) for x in re.findall(r"about (\d+(?:\.\d+)?) s of CPU", text)]
    memory = [float(x) for x in re.findall(r"s of CPU[^.;]*? and (\d+(?:\.\d+)?) GB", text)]
    orders = [int(x) for x in re.findall(r"order (\d+) on this VER", text)]
    assert cpu or orders, f"{page.name} quotes no first-run figure: drop it from FIRST_RUN_PAGES"
    for value in cpu:
        assert abs(value - record["cpu_seconds"]) <= 0.2 * record["cpu_seconds"], (page.name, value, record)
    for value in memory:
        assert abs(value - record["peak_gb"]) <= 0.1, (page.name, value, record)
    for value in orders:
        assert value == record["order"], (page.name, value, record)
    assert record["method"] == "krylov" and "Krylov" in text


def test_the_automatic_time_grid_quoted_by_the_scene_page_is_the_rules() -> None:
    """docs/guide/scene.md quotes what `end = "auto"`, `dt = "auto"` give on the shipped wood scene."""
    import tomllib

    from aromm.scene.scene_file import scene_from_dict

    quoted = re.search(r"end = ([\d.]+) s, dt = ([\d.]+) s \((\d+) outputs\)", SCENE_PAGE.read_text(encoding="utf-8"))
    assert quoted is not None
    path = ROOT / "data" / "scenes" / "wood_s1.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["time"] = {"end": "auto", "dt": "auto"}
    grid = scene_from_dict(data, path=path).time
    assert grid is not None
    assert (f"{grid.end:.6g}", f"{grid.dt:.6g}", round(grid.end / grid.dt)) == (
        quoted.group(1), quoted.group(2), int(quoted.group(3)))
