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

# the environment the tests run in first (CI's lowest-versions stage runs its interpreter without activating it)
LINT = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
pytestmark = pytest.mark.skipif(LINT is None, reason="import-linter is a test extra (pip install '.[test]')")


def lint(root: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` on the tree at ``root`` (its own pyproject.toml), importing from that tree."""
    assert LINT is not None
    return subprocess.run([LINT, "--config", str(root / "pyproject.toml"), "--no-cache"], cwd=root,
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
    assert r.wing_cycles == []
    assert r.upward == []


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


def _modules() -> list[str]:
    return sorted(".".join(p.relative_to(ROOT).with_suffix("").parts)
                  for package in ("aromm", "inverse") for p in (ROOT / package).rglob("*.py"))


def test_no_module_is_hidden_behind_a_name_of_its_package() -> None:
    """``package.name`` is the module ``package/name.py`` itself, never a function or class re-exported under the
    module's name (``from inverse.optimisers.pso import pso`` hid the module before)."""
    import importlib

    hidden = []
    for dotted in _modules():
        package, _, name = dotted.rpartition(".")
        if name == "__init__" or not package:
            continue
        owner = importlib.import_module(package)  # the package only: a module may need an optional extra
        found = getattr(owner, name, None)
        if found is not None and getattr(found, "__name__", None) != dotted:
            hidden.append(dotted)
    assert hidden == []


#: Pairs one letter apart that stay: the two discretisations' conventional names (finite elements, discrete
#: elements), wings named by the floor plan itself.
ONE_LETTER_ALLOWED = {("dem", "fem")}


def _one_letter_apart(a: str, b: str) -> bool:
    if a == b or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        return sum(x != y for x, y in zip(a, b, strict=True)) == 1
    short, long = sorted((a, b), key=len)
    return any(long[:i] + long[i + 1:] == short for i in range(len(long)))


def test_no_two_module_names_one_letter_apart() -> None:
    names = sorted({d.rsplit(".", 1)[-1] for d in _modules()} - {"__init__"}
                   | {p.name for p in (ROOT / "aromm").iterdir() if (p / "__init__.py").exists()})
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:] if _one_letter_apart(a, b)]
    assert [p for p in pairs if p not in ONE_LETTER_ALLOWED] == []


def test_no_library_file_over_450_lines() -> None:
    files = [p for package in ("aromm", "inverse") for p in (ROOT / package).rglob("*.py")]
    lines = {p.relative_to(ROOT).as_posix(): len(p.read_text(encoding="utf-8").splitlines()) for p in files}
    long = {name: n for name, n in lines.items() if n > 450}
    assert long == {}


@pytest.mark.parametrize("package", ["aromm", "inverse"])
def test_the_public_names_resolve(package: str) -> None:
    """Every name of the public contract (``__all__`` of aromm and inverse, docs/design.md) is importable."""
    import importlib

    module = importlib.import_module(package)
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == []


def test_the_documented_entry_points_are_the_api_s() -> None:
    """``aromm.simulate``, ``reduce``, ``homogenize`` and ``mean_capacity`` are the engine-choosing ones."""
    import aromm
    from aromm import api

    for name in ("simulate", "reduce", "homogenize", "mean_capacity"):
        assert getattr(aromm, name) is getattr(api, name)
