"""scripts/regenerate_notebooks.py stores outputs computed with AROMM_FULL=1, and only after a complete run."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import nbformat
import pytest
from nbclient.exceptions import CellExecutionError

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "regenerate_notebooks.py"


def _script():  # the script is not part of a package
    spec = importlib.util.spec_from_file_location("regenerate_notebooks", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _notebook(path: Path, source: str) -> None:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(source)]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(nb, path)


def test_outputs_are_stored_with_the_full_size_flag(tmp_path: Path) -> None:
    path = tmp_path / "probe.ipynb"
    _notebook(path, "import os\nimport matplotlib.pyplot as plt\nprint(os.environ['AROMM_FULL'])\nplt.plot([0, 1])")
    _script().regenerate(path, tmp_path / "cache", timeout=120)
    nb = nbformat.read(path, as_version=4)
    assert nb.cells[0].outputs[0]["text"].split() == ["1"]
    assert any("image/png" in o.get("data", {}) for o in nb.cells[0].outputs), "the figure was not stored"
    assert nb.metadata["aromm"]["full"] is True and nb.metadata["aromm"]["wall_seconds"] > 0


def test_a_failing_notebook_is_left_untouched(tmp_path: Path) -> None:
    path = tmp_path / "broken.ipynb"
    _notebook(path, "raise RuntimeError('no')")
    before = path.read_bytes()
    with pytest.raises(CellExecutionError):
        _script().regenerate(path, tmp_path / "cache", timeout=120)
    assert path.read_bytes() == before
