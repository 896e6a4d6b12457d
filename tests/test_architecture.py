"""The floor plan is a contract: import-linter's layers (pyproject.toml ``[tool.importlinter]``) hold on the tree,
a deliberately wrong import breaks them, and the pages that describe the layers quote the contract."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
from floor_plan import contract_layers, report  # noqa: E402

LINT = shutil.which("lint-imports")
pytestmark = pytest.mark.skipif(LINT is None, reason="import-linter is a test extra (pip install '.[test]')")


def lint(root: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` on the tree at ``root`` (its own pyproject.toml), importing from that tree."""
    assert LINT is not None
    return subprocess.run([LINT, str(root / "pyproject.toml"), "--no-cache"], cwd=root,
                          capture_output=True, text=True, env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"},
                          check=False)


def test_the_contract_holds_on_the_tree() -> None:
    result = lint(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout


def test_a_wrong_import_breaks_the_contract(tmp_path: Path) -> None:
    """A copy of the packages where the core imports the reduced model (an arrow up the layers), and one where
    a numerical wing imports an engine: each breaks the layers contract and is named."""
    for source, wrong in (("aromm/core/errors.py", "from aromm.reduction import rom"),
                          ("aromm/full/analytic.py", "from aromm.engines import check_engine")):
        tree = tmp_path / source.replace("/", "_")
        for part in ("aromm", "inverse"):
            shutil.copytree(ROOT / part, tree / part, ignore=shutil.ignore_patterns("__pycache__"))
        shutil.copy(ROOT / "pyproject.toml", tree / "pyproject.toml")
        path = tree / source
        path.write_text(path.read_text(encoding="utf-8") + f"\n{wrong}  # noqa\n", encoding="utf-8")
        result = lint(tree)
        assert result.returncode != 0
        assert "BROKEN" in result.stdout and source.replace("/", ".").removesuffix(".py") in result.stdout


def test_no_cycle_between_wings_and_no_arrow_up() -> None:
    r = report(ROOT, contract_layers(ROOT / "pyproject.toml"))
    assert r["wing_cycles"] == []
    assert r["upward"] == []


def _quoted_layers(page: Path) -> list[str]:
    """The lines of the ```` ```layers ```` block of a page."""
    text = page.read_text(encoding="utf-8")
    block = re.search(r"```text\n# layers.*?\n(.*?)```", text, flags=re.S)
    assert block, f"{page.name} has no '# layers' text block"
    return [line.split("#")[0].strip() for line in block.group(1).splitlines() if line.split("#")[0].strip()]


@pytest.mark.parametrize("page", ["docs/design.md", "CONTRIBUTING.md"])
def test_the_pages_quote_the_contract(page: str) -> None:
    layers = [" | ".join(layer) for layer in contract_layers(ROOT / "pyproject.toml")]
    assert _quoted_layers(ROOT / page) == layers


def test_every_package_folder_is_in_a_layer() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]
    listed = {w for layer in contract_layers(ROOT / "pyproject.toml") for w in layer}
    wings = {f"aromm.{p.name}" for p in (ROOT / "aromm").iterdir() if (p / "__init__.py").exists()}
    wings |= {f"aromm.{p.stem}" for p in (ROOT / "aromm").glob("*.py") if p.stem != "__init__"}
    assert wings == listed, f"wings missing from the layers: {sorted(wings - listed)}; extra: {sorted(listed - wings)}"
    assert config["root_packages"] == ["aromm", "inverse"]

