"""Output files: folders created, unwritable paths named, atomic replacement (aromm.core.files)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from aromm.core.errors import InputError
from aromm.core.files import atomic_write, check_output, output_path, read_npz
from aromm.core.observables import TIME_SERIES, Observables, read_csv, write_csv, written_by_write_csv
from aromm.core.vocabulary import FACES


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


def test_an_input_is_recognised_through_every_spelling_and_never_replaced(tmp_path: Path) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text("x")
    (tmp_path / "sym.csv").symlink_to("scene.toml")
    os.link(scene, tmp_path / "hard.csv")
    (tmp_path / "sub").mkdir()
    spellings = [scene, tmp_path / "." / "scene.toml", tmp_path / "sub" / ".." / "scene.toml",
                 tmp_path / "sym.csv", tmp_path / "hard.csv"]
    for path in spellings:
        with pytest.raises(InputError, match="is the scene, an input of this command"):
            check_output(path, TIME_SERIES, inputs=[(scene, "the scene")], force=True)
    assert scene.read_text() == "x"


def test_existing_outputs_are_replaced_only_when_ours_or_forced(tmp_path: Path) -> None:
    ours, foreign = tmp_path / "ours.csv", tmp_path / "lab.csv"
    write_csv(Observables(np.array([0.5, 1.0]), {"z0": np.array([1.0, 2.0])}), ours)
    foreign.write_text("t,z0\n0,20.5\n")
    assert check_output(ours, TIME_SERIES) == ours
    with pytest.raises(InputError, match=r"--out: .*lab\.csv exists and is not a time-series CSV.*--force"):
        check_output(foreign, TIME_SERIES)
    assert check_output(foreign, TIME_SERIES, force=True) == foreign
    with pytest.raises(InputError, match="is a folder"):
        check_output(tmp_path, TIME_SERIES, force=True)
    with pytest.raises(InputError, match=r"ours\.csv is a file, not a folder"):
        check_output(ours / "x.csv", TIME_SERIES)
    assert not (tmp_path / "new").exists() and check_output(tmp_path / "new" / "a.csv", TIME_SERIES)
    assert not (tmp_path / "new").exists()  # checking creates nothing


@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=2, max_size=30),
       st.lists(st.sampled_from(FACES), min_size=1, max_size=6, unique=True))
def test_whatever_write_csv_writes_is_recognised_as_ours(values: list[float], faces: list[str]) -> None:
    """Otherwise re-running a command would need --force: the recogniser must accept every table we write."""
    t = np.arange(1.0, len(values) + 1.0)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "y.csv"
        write_csv(Observables(t, {f: np.roll(values, i) for i, f in enumerate(faces)}), path)
        assert written_by_write_csv(path)
        assert read_csv(path).as_array().tolist() == Observables(
            t, {f: np.roll(values, i) for i, f in enumerate(faces)}).as_array().tolist()


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_atomic_files_get_the_usual_permissions(tmp_path: Path, umask: int) -> None:
    """0666 & ~umask, as open() would give (tempfile.mkstemp alone gives 0600)."""
    old = os.umask(umask)
    try:
        with atomic_write(tmp_path / "a.csv", "file") as fh:
            fh.write("x")
        (tmp_path / "reference").write_text("x")
    finally:
        os.umask(old)
    assert (tmp_path / "a.csv").stat().st_mode & 0o777 == 0o666 & ~umask
    assert (tmp_path / "a.csv").stat().st_mode == (tmp_path / "reference").stat().st_mode


def test_damaged_archives_are_refused_by_name(tmp_path: Path) -> None:
    good = tmp_path / "good.npz"
    np.savez(good, problem=np.asarray("p"), x=np.arange(3))
    (tmp_path / "empty.npz").write_bytes(b"")
    (tmp_path / "cut.npz").write_bytes(good.read_bytes()[:120])
    np.save(tmp_path / "single.npy", np.arange(3))
    assert read_npz(good, "checkpoint", ("problem",))["x"].tolist() == [0, 1, 2]
    for name, needle in (("empty.npz", "empty file"), ("cut.npz", "not a readable checkpoint"),
                         ("single.npy", "single array"), ("none.npz", "not found")):
        with pytest.raises(InputError, match=needle):
            read_npz(tmp_path / name, "checkpoint", ("problem",))
    with pytest.raises(InputError, match=r"missing array\(s\) centers"):
        read_npz(good, "packing", ("centers",))
