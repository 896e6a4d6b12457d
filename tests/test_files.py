"""Output files: folders created, unwritable paths named, atomic replacement (aromm.files)."""

from __future__ import annotations

from pathlib import Path

import pytest

from aromm.errors import InputError
from aromm.files import atomic_write, output_path


def test_output_path_creates_folders_and_names_a_blocked_path(tmp_path: Path) -> None:
    assert output_path(tmp_path / "a" / "b" / "fit.png", "plot").parent.is_dir()
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match=r"file[/\\]y\.csv: cannot write the plot"):
        output_path(tmp_path / "file" / "y.csv", "plot")


def test_interrupted_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "m.csv"
    target.write_text("old\n")
    with pytest.raises(KeyboardInterrupt), atomic_write(target, "measurement file") as fh:
        fh.write("half a ")
        raise KeyboardInterrupt
    assert target.read_text() == "old\n"
    with atomic_write(target, "measurement file") as fh:
        fh.write("new\n")
    assert target.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv"]
