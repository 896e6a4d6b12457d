"""Bad inputs for every command (issue 10): the case list of tests/test_faults.py and its runner.

Every case runs in a copy of one small folder (:func:`make_template`: a 4³ scene, its image, measurements, a
packing) and states the exit code and the words its message must contain (the file, option or key, and what
is allowed).  :func:`run` executes a case in-process through ``aromm.cli.main`` (or in a subprocess, to catch
tracebacks and console encodings) and returns what happened; ``python tests/test_faults.py --table`` prints
the table of cases from the same list.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from inverse_cases import tracheids
from scene_text import scenario_1

from aromm.cli import main
from aromm.core.observables import Observables, write_csv
from aromm.dem.packing import cubic_lattice

Setup = Callable[[Path], None]
Patch = Callable[[pytest.MonkeyPatch], None]


@dataclass(frozen=True)
class Case:
    """``aromm <argv>`` in the case folder ends with ``code`` and a message containing every one of ``names``."""

    id: str
    argv: tuple[str, ...]
    code: int
    names: tuple[str, ...]
    setup: tuple[Setup, ...] = ()
    patch: Patch | None = None
    env: dict[str, str] = field(default_factory=dict)
    subprocess: bool = False
    stdout: tuple[str, ...] = ()  # what stdout must contain (a result printed before a failed extra)


@dataclass(frozen=True)
class Outcome:
    code: int
    out: str
    err: str
    changed: tuple[str, ...]  # inputs whose bytes changed
    created: tuple[str, ...]  # files that did not exist before

    @property
    def message(self) -> str:
        """The first line of the message (after click's usage lines)."""
        lines = [ln for ln in self.err.splitlines() if ln.strip()]
        for prefixes in (("aromm: error", "aromm: numerical", "aromm: interrupted", "Error:"), ("aromm:",)):
            chosen = [ln for ln in lines if ln.startswith(prefixes)]
            if chosen:
                return chosen[0]
        return lines[0] if lines else ""


# --- the case folder ------------------------------------------------------------------------------------------

SCENE = scenario_1("labels.npy", repr(231e-6 / 4), "20.0", "1.0")
STEADY = """
[geometry]
generator = "sphere_in_cube"
n = 4
voxel_size = 1e-4
[phases.matrix]
label = 0
k = 1.0
[phases.sphere]
label = 1
k = 10.0
[boundary.z0]
T = 1.0
[boundary.z1]
T = 0.0
[outputs]
mean_T = ["z0", "z1"]
"""


def make_template(folder: Path) -> Path:
    """The files every case starts from (a few kB; our own outputs written by our own writers)."""
    folder.mkdir(parents=True, exist_ok=True)
    np.save(folder / "labels.npy", tracheids(4))
    (folder / "scene.toml").write_text(SCENE, encoding="utf-8")
    (folder / "steady.toml").write_text(STEADY, encoding="utf-8")
    t = np.arange(1.0, 21.0)
    write_csv(Observables(t, {"z0": 0.1 * t, "z1": 0.05 * t}), folder / "y.csv")
    cubic_lattice(3, 1e-3).save(folder / "pack.npz")
    return folder


def text(name: str, content: str) -> Setup:
    def write(d: Path) -> None:
        (d / name).parent.mkdir(parents=True, exist_ok=True)
        (d / name).write_text(content, encoding="utf-8")
    return write


def scene_with(name: str, old: str, new: str) -> Setup:
    """``name``: scene.toml with ``old`` replaced by ``new``."""
    assert old in SCENE, old
    return text(name, SCENE.replace(old, new))


def forged_npy(name: str) -> Setup:
    """A 1 kB ``.npy`` whose header claims 100000³ int32 voxels (4e15 bytes)."""
    def write(d: Path) -> None:
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(header, {"descr": "<i4", "fortran_order": False,
                                                      "shape": (100000, 100000, 100000)})
        (d / name).write_bytes(header.getvalue() + bytes(1024))
    return write


def head(name: str, source: str, size: int) -> Setup:
    """``name``: the first ``size`` bytes of ``source`` (a truncated copy)."""
    def write(d: Path) -> None:
        (d / name).write_bytes((d / source).read_bytes()[:size])
    return write


def link(name: str, target: str, hard: bool = False) -> Setup:
    """``name``: a symbolic (relative) or hard link to ``target``."""
    def make(d: Path) -> None:
        if hard:
            os.link(d / target, d / name)
        else:
            os.symlink(target, d / name)
    return make


def folder(name: str) -> Setup:
    def make(d: Path) -> None:
        (d / name).mkdir(parents=True)
    return make


def packing_with_nan(d: Path) -> None:
    np.savez(d / "nan.npz", centers=np.zeros((2, 3)), radii=np.array([1.0, np.nan]), box=np.ones(3),
             periodic=np.array(True))


def checkpoint_copy(d: Path) -> None:
    """A real checkpoint of another problem (written by our own writer)."""
    from inverse import checkpoint as ckpt

    ckpt.save(d / "other.npz", "another problem", {"stage": np.asarray(0)})


def fail_vtu_write(mp: pytest.MonkeyPatch) -> None:
    """The disk fills up while the final field is written (after the table and observables.csv)."""
    def no_space(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device")
    mp.setattr("meshio.vtu.write", no_space)


def fail_plot_write(mp: pytest.MonkeyPatch) -> None:
    def no_space(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device")
    mp.setattr("matplotlib.figure.Figure.savefig", no_space)


def ctrl_c_after_two_steps(mp: pytest.MonkeyPatch) -> None:
    """Ctrl-C during the second swarm iteration (the checkpoint of the first is on disk)."""
    import inverse.identification as command  # the command imports identify from there when it runs

    real = command.identify

    def interrupted(*args: object, progress: Callable[[object], None], **kwargs: object) -> object:
        def report(p: object) -> None:
            progress(p)
            if getattr(p, "step", 0) >= 2:
                raise KeyboardInterrupt
        return real(*args, progress=report, **kwargs)  # type: ignore[arg-type]
    mp.setattr(command, "identify", interrupted)


# --- the cases ------------------------------------------------------------------------------------------------

ID = ("identify", "scene.toml", "--measurements", "y.csv", "--model", "full", "--particles", "2", "--iterations", "1")
K = ("--unknown", "fibre.k=0.05:1")
CSV_ROWS = "t,z0,z1\n1.0,0.1,0.05\n2.0,0.2,0.1\n"

CASES: tuple[Case, ...] = (
    # simulate
    Case("simulate-missing-scene", ("simulate", "missing.toml"), 2, ("missing.toml", "not found")),
    Case("simulate-not-toml", ("simulate", "bad.toml"), 2, ("bad.toml", "not a valid TOML"),
         (text("bad.toml", "[geometry\nimage = 1"),)),
    Case("simulate-unknown-section", ("simulate", "bad.toml"), 2, ("bad.toml", "bogus", "allowed"),
         (scene_with("bad.toml", "[initial]", "[bogus]\nx = 1\n[initial]"),)),
    Case("simulate-generator-option-type", ("simulate", "bad.toml"), 2,
         ("bad.toml", "geometry", "sphere_in_cube", "n must be a positive integer"),
         (text("bad.toml", STEADY.replace("n = 4", 'n = "four"')),)),
    Case("simulate-generator-seed", ("simulate", "bad.toml"), 2, ("bad.toml", "geometry.seed", "non-negative integer"),
         (text("bad.toml", STEADY.replace('generator = "sphere_in_cube"\nn = 4',
                                          'generator = "wood"\nshape = [4, 4, 4]\nseed = "x"')),)),
    Case("simulate-missing-image", ("simulate", "bad.toml"), 2, ("bad.toml", "geometry.image", "file not found"),
         (scene_with("bad.toml", "labels.npy", "nowhere.npy"),)),
    Case("simulate-negative-k", ("simulate", "bad.toml"), 2, ("bad.toml", "phases.fibre.k", ">= 0"),
         (scene_with("bad.toml", "k = 0.3", "k = -0.3"),)),
    Case("simulate-moisture-key-without-section", ("simulate", "bad.toml"), 2,
         ("bad.toml", "phases.fibre.xi", "[moisture] section"),
         (scene_with("bad.toml", "k = 0.3", "k = 0.3\nxi = 20.0"),)),
    Case("simulate-moisture-phase-without-xi", ("simulate", "bad.toml"), 2,
         ("bad.toml", "phases.", ".xi", "missing", "xi, D_phi, delta_p"),
         (scene_with("bad.toml", "[initial]", "[moisture]\nT_ref = 20.0\n[initial]"),)),
    Case("simulate-insulating-phase-in-a-transient", ("simulate", "bad.toml"), 2,
         ("bad.toml", "phases.fibre.k", "k = 0", "steady scenes"), (scene_with("bad.toml", "k = 0.3", "k = 0.0"),)),
    Case("simulate-insulating-phase-in-an-fv-transient", ("simulate", "bad.toml", "--discretisation", "fv"), 2,
         ("bad.toml", "phases.fibre.k", "k = 0", "steady scenes"), (scene_with("bad.toml", "k = 0.3", "k = 0.0"),)),
    Case("simulate-implausible-capacity", ("simulate", "bad.toml"), 2,
         ("bad.toml", "phases.fibre.c", "1e+308 J/(m", "plausible range", "unit slip"),
         (scene_with("bad.toml", "c = 4.0e6", "c = 1e308"),)),
    Case("simulate-implausible-voxel", ("simulate", "bad.toml"), 2,
         ("bad.toml", "geometry.voxel_size", "1e+06 m", "plausible range"),
         (scene_with("bad.toml", f"voxel_size = {231e-6 / 4!r}", "voxel_size = 1e6"),)),
    Case("simulate-unknown-discretisation", ("simulate", "s1.toml", "--discretisation", "fem"), 2,
         ("--discretisation", "'fem'", "q1", "fv")),
    Case("simulate-initial-below-absolute-zero", ("simulate", "bad.toml"), 2,
         ("bad.toml", "initial.T", "-300", "below absolute zero"),
         (scene_with("bad.toml", "[initial]\nT = 0.0", "[initial]\nT = -300.0"),)),
    Case("simulate-T_ext-below-absolute-zero", ("simulate", "bad.toml"), 2,
         ("bad.toml", "boundary.z1.T_ext", "below absolute zero"),
         (scene_with("bad.toml", "T_ext = 0.0", "T_ext = -500.0"),)),
    Case("simulate-negative-dt", ("simulate", "bad.toml"), 2, ("bad.toml", "time.dt", "> 0"),
         (scene_with("bad.toml", "dt = 1.0", "dt = -1.0"),)),
    Case("simulate-time-end-word", ("simulate", "bad.toml"), 2, ("bad.toml", "time.end", "number of seconds", "auto"),
         (scene_with("bad.toml", "end = 20.0", "end = 'soon'"),)),
    Case("simulate-too-many-steps", ("simulate", "bad.toml"), 2, ("bad.toml", "time steps", "allowed"),
         (scene_with("bad.toml", "dt = 1.0", "dt = 1e-9"),)),
    Case("simulate-singular-steady", ("simulate", "bad.toml"), 2, ("bad.toml", "boundary", "T"),
         (text("bad.toml", STEADY.replace("T = 1.0", "flux = 1.0").replace("T = 0.0", "flux = -1.0")),)),
    Case("simulate-refine-0", ("simulate", "scene.toml", "--refine", "0"), 2, ("--refine", ">=1")),
    Case("simulate-out-is-a-file", ("simulate", "scene.toml", "--out", "y.csv"), 2, ("--out", "y.csv", "not a folder")),
    Case("simulate-out-foreign-csv", ("simulate", "scene.toml", "--out", "res"), 2,
         ("--out", "observables.csv", "not a time-series CSV", "--force"),
         (text("res/observables.csv", "t,z0\n0,1\n"),)),
    Case("simulate-out-foreign-vtu", ("simulate", "scene.toml", "--out", "res"), 2,
         ("--out", "field.vtu", "--force"), (text("res/field.vtu", "my notes\n"),)),
    Case("simulate-out-is-history-input", ("simulate", "hist.toml", "--out", "res"), 2,
         ("--out", "observables.csv", "an input", "not even with --force"),
         (text("res/observables.csv", "t,v\n0.0,1.0\n30.0,1.0\n"),
          scene_with("hist.toml", "flux = 500.0", 'flux = "res/observables.csv"'))),
    Case("simulate-out-without-outputs", ("simulate", "bad.toml", "--out", "res"), 2, ("--out", "[outputs] mean_T"),
         (scene_with("bad.toml", 'mean_T = ["z0", "z1"]', "mean_T = []"),)),
    Case("simulate-field-write-fails", ("simulate", "scene.toml", "--out", "res"), 3,
         ("field", "not written", "No space left"), patch=fail_vtu_write, stdout=("t (s)",)),
    # homogenize
    Case("homogenize-rtol-nan", ("homogenize", "scene.toml", "--rtol", "nan"), 2, ("--rtol", "finite")),
    Case("homogenize-boundary", ("homogenize", "scene.toml", "--boundary", "sideways"), 2,
         ("--boundary", "periodic")),
    Case("homogenize-solver", ("homogenize", "scene.toml", "--solver", "magic"), 2, ("--solver", "cholmod")),
    # measure
    Case("measure-out-is-scene", ("measure", "scene.toml", "--homogeneous", "--out", "scene.toml", "--force"), 2,
         ("--out", "scene.toml", "the scene file", "not even with --force")),
    Case("measure-out-is-image", ("measure", "scene.toml", "--homogeneous", "--out", "./labels.npy"), 2,
         ("--out", "labels.npy", "named by the scene")),
    Case("measure-out-symlink-to-scene", ("measure", "scene.toml", "--homogeneous", "--out", "s.csv"), 2,
         ("--out", "s.csv", "the scene file"), (link("s.csv", "scene.toml"),)),
    Case("measure-out-hardlink-to-scene", ("measure", "scene.toml", "--homogeneous", "--out", "h.csv"), 2,
         ("--out", "h.csv", "the scene file"), (link("h.csv", "scene.toml", hard=True),)),
    Case("measure-out-foreign-csv", ("measure", "scene.toml", "--homogeneous", "--out", "lab.csv"), 2,
         ("--out", "lab.csv", "not a time-series CSV", "--force"), (text("lab.csv", "t,z0\n0,20.5\n60,21.25\n"),)),
    Case("measure-out-folder", ("measure", "scene.toml", "--homogeneous", "--out", "res"), 2,
         ("--out", "res", "is a folder"), (folder("res"),)),
    Case("measure-out-under-a-file", ("measure", "scene.toml", "--homogeneous", "--out", "y.csv/m.csv"), 2,
         ("--out", "y.csv", "not a folder")),
    Case("measure-noise-nan", ("measure", "scene.toml", "--homogeneous", "--noise", "nan", "--out", "m.csv"), 2,
         ("--noise", "finite")),
    Case("measure-noise-inf", ("measure", "scene.toml", "--homogeneous", "--noise", "inf", "--out", "m.csv"), 2,
         ("--noise", "finite")),
    Case("measure-perturb", ("measure", "scene.toml", "--homogeneous", "--perturb", "-1", "--out", "m.csv"), 2,
         ("--perturb", "-1")),
    Case("measure-seed", ("measure", "scene.toml", "--homogeneous", "--seed", "-1", "--out", "m.csv"), 2,
         ("--seed", ">=0")),
    Case("measure-steady-scene", ("measure", "steady.toml", "--homogeneous", "--out", "m.csv"), 2,
         ("steady.toml", "[time]", "end and dt")),
    # identify
    Case("identify-representativeness-without-phase-unknown", (*ID, "--unknown", "z1.h=1:50",
                                                                "--representativeness-check"), 2,
         ("--representativeness-check", "<phase>.k", "--unknown")),
    Case("identify-repeat-with-representativeness", (*ID, *K, "--repeat", "2", "--representativeness-check"), 2,
         ("--repeat", "--representativeness-check")),
    Case("identify-repeat-with-discretisation-check", (*ID, *K, "--repeat", "2", "--discretisation-check"), 2,
         ("--repeat", "--discretisation-check")),
    Case("identify-checkpoint-is-measurements", (*ID, *K, "--checkpoint", "y.csv"), 2,
         ("--checkpoint", "y.csv", "measurement file", "not even with --force")),
    Case("identify-checkpoint-foreign", (*ID, *K, "--checkpoint", "notes.npz"), 2,
         ("--checkpoint", "notes.npz", "not an identification checkpoint", "--force"), (text("notes.npz", "mine"),)),
    Case("identify-checkpoint-empty", (*ID, *K, "--checkpoint", "e.npz", "--resume", "--force"), 2,
         ("e.npz", "not a readable identification checkpoint", "empty file"), (text("e.npz", ""),)),
    Case("identify-checkpoint-truncated", (*ID, *K, "--checkpoint", "t.npz", "--resume", "--force"), 2,
         ("t.npz", "not a readable identification checkpoint"), (checkpoint_copy, head("t.npz", "other.npz", 100))),
    Case("identify-checkpoint-other-problem", (*ID, *K, "--checkpoint", "other.npz", "--resume"), 2,
         ("other.npz", "another identification problem", "without --resume"), (checkpoint_copy,)),
    Case("identify-negative-bound", (*ID, "--unknown", "fibre.k=-1:1"), 2, ("--unknown", "fibre.k", "0 < LOW")),
    Case("identify-zero-capacity-bound", (*ID, "--unknown", "gas.c=0:1e4"), 2, ("--unknown", "gas.c", "0 < LOW")),
    Case("identify-repeated-unknown", (*ID, *K, "--unknown", "fibre.k=0.1:2"), 2, ("--unknown", "fibre.k", "twice")),
    Case("identify-unknown-name", (*ID, "--unknown", "fibre.q=0:1"), 2,
         ("--unknown", "fibre.q", "allowed", "fibre.k", "time_offset")),
    Case("identify-unknown-syntax", (*ID, "--unknown", "fibre.k=0.05-1"), 2, ("--unknown", "NAME=LOW:HIGH")),
    Case("identify-unknown-nan", (*ID, "--unknown", "fibre.k=nan:1"), 2, ("--unknown", "finite")),
    Case("identify-measurements-missing", (*ID[:3], "none.csv", *ID[4:], *K), 2, ("none.csv", "cannot read")),
    Case("identify-measurements-empty", (*ID[:3], "m.csv", *ID[4:], *K), 2, ("m.csv", "empty file", "header"),
         (text("m.csv", ""),)),
    Case("identify-measurements-header", (*ID[:3], "m.csv", *ID[4:], *K), 2, ("m.csv", "line 1", "t,<face>"),
         (text("m.csv", "when,z0\n1,2\n"),)),
    Case("identify-order-with-full-model", (*ID, *K, "--order", "60"), 2, ("--order", "--model full")),
    Case("simulate-order-with-full-model", ("simulate", "scene.toml", "--order", "60"), 2, ("--order", "--model full")),
    Case("simulate-npy-header-claims-more", ("simulate", "bad.toml"), 2, ("forged.npy", "header claims", "truncated"),
         (forged_npy("forged.npy"), scene_with("bad.toml", "labels.npy", "forged.npy"))),
    Case("identify-measurements-open-quote", (*ID[:3], "m.csv", *ID[4:], *K), 2, ("m.csv", "line 3", "quote"),
         (text("m.csv", 't,z0,z1\n1,0.1,0.05\n2,"0.2,0.1\n3,0.3,0.15\n'),)),
    Case("simulate-history-open-quote", ("simulate", "hist.toml"), 2, ("q.csv", "line 2", "quote"),
         (text("q.csv", 't,flux\n0,"500\n10,500\n'), scene_with("hist.toml", "flux = 500.0", 'flux = "q.csv"'))),
    Case("identify-measurements-face", (*ID[:3], "m.csv", *ID[4:], *K), 2, ("m.csv", "'x0'", "allowed: z0, z1"),
         (text("m.csv", "t,x0\n1,2\n"),)),
    Case("identify-measurements-cell", (*ID[:3], "m.csv", *ID[4:], *K), 2, ("m.csv", "line 3", "not a number"),
         (text("m.csv", CSV_ROWS.replace("0.2,", "warm,")),)),
    Case("identify-measurements-time-order", (*ID[:3], "m.csv", *ID[4:], *K), 2,
         ("m.csv", "line 3", "strictly increasing"), (text("m.csv", CSV_ROWS.replace("2.0,", "1.0,")),)),
    Case("identify-measurements-past-end", (*ID[:3], "m.csv", *ID[4:], *K), 2, ("m.csv", "[time] end", "reduced"),
         (text("m.csv", CSV_ROWS.replace("2.0,", "99.0,")),)),
    Case("identify-plot-suffix", (*ID, *K, "--plot", "fit.xyz"), 2,
         ("--plot", "fit.xyz", "supported suffixes", ".png")),
    Case("identify-plot-is-input", (*ID, *K, "--plot", "fig.png"), 2, ("--plot", "fig.png", "the scene file"),
         (link("fig.png", "scene.toml"),)),
    Case("identify-plot-is-checkpoint", (*ID, *K, "--plot", "a.png", "--checkpoint", "a.png"), 2,
         ("--plot", "--checkpoint", "same file")),
    Case("identify-noise-std-inf", (*ID, *K, "--noise-std", "inf"), 2, ("--noise-std", "finite")),
    Case("identify-noise-std-zero", (*ID, *K, "--noise-std", "0"), 2, ("--noise-std", ">0")),
    Case("identify-resume-alone", (*ID, *K, "--resume"), 2, ("--resume", "--checkpoint")),
    Case("identify-seed", (*ID, *K, "--seed", "-3"), 2, ("--seed", ">=0")),
    Case("identify-cache-is-a-file", (*ID[:5], "reduced", *ID[6:], *K), 2, ("cache", "AROMM_CACHE_DIR", "not a folder"),
         env={"AROMM_CACHE_DIR": "y.csv"}),
    Case("identify-interrupted", (*ID[:-1], "30", *K, "--checkpoint", "run.npz"), 130,
         ("interrupted", "resume with --resume", "run.npz"), patch=ctrl_c_after_two_steps),
    Case("identify-plot-write-fails", (*ID, *K, "--plot", "fit.png", "--json"), 3,
         ("plot", "not written", "No space left"), patch=fail_plot_write, stdout=('"estimates"',)),
    # reduce
    Case("reduce-cache-dir-is-a-file", ("reduce", "scene.toml", "--cache-dir", "y.csv"), 2,
         ("--cache-dir", "y.csv", "not a folder")),
    Case("reduce-reference-missing", ("reduce", "scene.toml", "--reference", "none.toml"), 2,
         ("none.toml", "not found")),
    Case("reduce-order-0", ("reduce", "scene.toml", "--order", "0"), 2, ("--order", ">=1")),
    Case("reduce-method", ("reduce", "scene.toml", "--method", "magic"), 2, ("--method", "aromm", "pod")),
    # bounds
    Case("bounds-phi", ("bounds", "--phi", "0.9", "--ratio", "10"), 2, ("--phi", "0.523599")),
    Case("bounds-ratio-nan", ("bounds", "--phi", "0.2", "--ratio", "nan"), 2, ("--ratio", "finite")),
    Case("bounds-contact-negative", ("bounds", "--phi", "0.2", "--ratio", "10", "--contact", "-1"), 2,
         ("--contact", "[0, inf)")),
    # dem
    Case("dem-pack-out-foreign", ("dem", "pack", "--out", "scene.toml"), 2,
         ("--out", "scene.toml", "not a packing", "--force")),
    Case("dem-pack-out-folder", ("dem", "pack", "--out", "res"), 2, ("--out", "res", "is a folder"), (folder("res"),)),
    Case("dem-pack-seed", ("dem", "pack", "--seed", "-1", "--out", "p.npz"), 2, ("--seed", ">=0")),
    Case("dem-pack-phi-nan", ("dem", "pack", "--phi", "nan", "--out", "p.npz"), 2, ("--phi", "finite")),
    Case("dem-calibrate-packing-missing", ("dem", "calibrate", "--packing", "none.npz"), 2,
         ("--packing", "none.npz", "dem pack")),
    Case("dem-calibrate-packing-empty", ("dem", "calibrate", "--packing", "e.npz"), 2,
         ("e.npz", "not a readable packing", "empty file"), (text("e.npz", ""),)),
    Case("dem-calibrate-packing-truncated", ("dem", "calibrate", "--packing", "t.npz"), 2,
         ("t.npz", "not a readable packing"), (head("t.npz", "pack.npz", 300),)),
    Case("dem-calibrate-packing-arrays", ("dem", "calibrate", "--packing", "o.npz"), 2,
         ("o.npz", "missing array", "centers, radii, box, periodic"), (checkpoint_copy, link("o.npz", "other.npz"))),
    Case("dem-calibrate-packing-nan", ("dem", "calibrate", "--packing", "nan.npz"), 2, ("nan.npz", "finite"),
         (packing_with_nan,)),
    Case("dem-homogenize-ratio-nan", ("dem", "homogenize", "--packing", "pack.npz", "--ratio", "nan"), 2,
         ("--ratio", "finite")),
    Case("dem-simulate-times-text", ("dem", "simulate", "--packing", "pack.npz", "--times", "a,b"), 2,
         ("--times", "comma-separated numbers")),
    Case("dem-simulate-times-order", ("dem", "simulate", "--packing", "pack.npz", "--times", "0.2,0.1"), 2,
         ("--times", "strictly increasing")),
    Case("dem-simulate-k", ("dem", "simulate", "--packing", "pack.npz", "--k", "-1"), 2, ("--k", ">0")),
    # a console that is not UTF-8, and tracebacks, in real processes
    Case("console-ascii-homogenize", ("homogenize", "scene.toml"), 0, (), env={"PYTHONIOENCODING": "ascii"},
         subprocess=True, stdout=("kbar (W/(m K))", "cbar (J/(m3 K))")),
    Case("console-latin1-error", ("identify", "scene.toml", "--measurements", "mesures_k̄_été.csv", *K), 2,
         ("mesures_kbar_été.csv", "cannot read"), env={"PYTHONIOENCODING": "latin-1"}, subprocess=True),
    Case("console-ascii-truncated-packing", ("dem", "calibrate", "--packing", "t.npz"), 2,
         ("t.npz", "not a readable packing"), (head("t.npz", "pack.npz", 300),), env={"PYTHONIOENCODING": "ascii"},
         subprocess=True),
)


# --- running a case -------------------------------------------------------------------------------------------

def digests(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file() and not p.is_symlink()}


def run(case: Case, work: Path, cache: Path) -> Outcome:
    """Run ``case`` in the folder ``work`` (a copy of the template); the cache folder is ``cache``."""
    for step in case.setup:
        step(work)
    before = digests(work)
    env = {"AROMM_CACHE_DIR": str(cache), **case.env}
    if case.subprocess:
        proc = subprocess.run([sys.executable, "-c", "import sys; from aromm.cli import main; sys.exit(main())",
                               *case.argv], cwd=work, env={**os.environ, **env}, capture_output=True, timeout=600,
                              check=False)
        code, encoding = proc.returncode, case.env.get("PYTHONIOENCODING", "utf-8")
        out, err = (proc.stdout.decode(encoding, "replace"), proc.stderr.decode(encoding, "replace"))
        if encoding == "ascii" and any(b > 127 for b in proc.stdout + proc.stderr):
            err += "\nnon-ASCII bytes on an ASCII console"
    else:
        stdout, stderr = io.StringIO(), io.StringIO()
        with pytest.MonkeyPatch.context() as mp:
            mp.chdir(work)
            for key, value in env.items():
                mp.setenv(key, value)
            if case.patch is not None:
                case.patch(mp)
            with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
                code = main(list(case.argv))
        out, err = stdout.getvalue(), stderr.getvalue()
    after = digests(work)
    changed = tuple(k for k, v in before.items() if after.get(k) != v)
    return Outcome(code, out, err, changed, tuple(sorted(set(after) - set(before))))


def prepared(template: Path, root: Path) -> Path:
    """A fresh copy of the template under ``root`` (symlinks kept as links)."""
    work = root / "work"
    shutil.copytree(template, work, symlinks=True)
    return work
