"""Laboratory CSVs (issue 22 item 6, issue 23 item 1): every logger quirk read from a small file written here, and
every impossible value refused naming the file, line and column (aromm.core.labcsv, aromm.core.labchecks).

The truths are the numbers written into each file (converted by hand: 0.5 min = 30 s, 293.65 K = 20.5 °C).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aromm.core.errors import InputError
from aromm.core.labchecks import kelvin_suspect, single_outlier
from aromm.core.labcsv import read_lab_csv
from inverse.measurements import load_measurements

OUT = ("z0", "z1", "tc1")


def write(tmp_path: Path, name: str, text: str, encoding: str = "utf-8") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode(encoding))
    return path


QUIRKS = {
    # quirk: (file name, content, encoding, expected t (s), expected z0 (°C), a note the reader must print)
    "comment and metadata lines": ("comments.csv", "# logger 7, serial 1234\n#\nt,z0\n0,20.5\n# pause\n1,21\n",
                                   "utf-8", [0, 1], [20.5, 21.0], None),
    "semicolon and decimal comma": ("semicolon.csv", "t;z0\n0;20,5\n1,5;21,25\n", "utf-8", [0, 1.5], [20.5, 21.25],
                                    "decimal comma"),
    "tab delimiter": ("tab.csv", "t\tz0\n0\t20.5\n1\t21\n", "utf-8", [0, 1], [20.5, 21.0], "tab"),
    "units row in min and °C": ("units.csv", "t,z0\nmin,°C\n0,20.5\n0.5,21\n", "utf-8", [0, 30], [20.5, 21.0],
                                "from min to s"),
    "units row in h and K": ("kelvin.csv", "time,z0\nh,K\n0,293.65\n0.01,294.15\n", "utf-8", [0, 36],
                             [20.5, 21.0], "from K to °C"),
    "units in the header, ms": ("header.csv", "t (ms),z0 [degC]\n0,20.5\n500,21\n", "utf-8", [0, 0.5],
                                [20.5, 21.0], "from ms to s"),
    "latin-1 degree sign": ("latin1.csv", "t;z0\ns;°C\n0;20,5\n1;21\n", "latin-1", [0, 1], [20.5, 21.0],
                            "latin-1"),
    "utf-8 byte-order mark and CRLF": ("bom.csv", "\ufefft,z0\r\n0,20.5\r\n1,21\r\n", "utf-8", [0, 1], [20.5, 21.0],
                                       None),
    "missing values dropped with a count": ("missing.csv", "t,z0\n0,20.5\n1,\n2,NA\n3,21\n", "utf-8", [0, 3],
                                            [20.5, 21.0], "2 row(s) with missing values dropped (line(s) 3, 4)"),
    "metadata lines without #": ("agilent.csv", "Datalogger: Agilent 34972A\nScan sweep 1\nt,z0\n0,20.5\n1,21\n",
                                 "utf-8", [0, 1], [20.5, 21.0], "2 metadata line(s) before the header skipped"),
    "German time column": ("zeit.csv", "Zeit;z0\ns;°C\n0;20,5\n1;21\n", "utf-8", [0, 1], [20.5, 21.0], None),
    "Excel's trailing empty columns": ("excel.csv", "t,z0,,\n0,20.5,,\n1,21,,\n", "utf-8", [0, 1], [20.5, 21.0],
                                       "2 empty trailing column(s) dropped"),
    "UTF-16 ('Unicode text')": ("unicode.csv", "t\tz0\n0\t20.5\n1\t21\n", "utf-16", [0, 1], [20.5, 21.0],
                                "UTF-16"),
    "clock times across midnight": ("clock.csv", "time,z0\n23:59:59,20.5\n00:00:01.5,21\n", "utf-8", [0, 2.5],
                                    [20.5, 21.0], "clock times converted to seconds after the first row (23:59:59)"),
}


@pytest.mark.parametrize("quirk", QUIRKS)
def test_each_logger_quirk_is_read_and_reported(tmp_path: Path, quirk: str) -> None:
    name, content, encoding, t, z0, note = QUIRKS[quirk]
    lab = read_lab_csv(write(tmp_path, name, content, encoding), OUT)
    np.testing.assert_allclose(lab.table.t, t, rtol=1e-12)
    np.testing.assert_allclose(lab.table.mean_T["z0"], z0, rtol=1e-12)
    if note is not None:
        assert any(note in n for n in lab.notes), lab.notes


def test_columns_are_mapped_onto_outputs_and_the_others_ignored(tmp_path: Path) -> None:
    path = write(tmp_path, "tc.csv", "Time;TC1;TC2;Ambient\ns;°C;°C;°C\n0;20,5;20,1;19\n60;21,0;20,4;19\n")
    lab = read_lab_csv(path, OUT, columns={"TC1": "z0", "TC2": "tc1"})
    assert lab.table.outputs == ("z0", "tc1")
    np.testing.assert_array_equal(lab.table.mean_T["tc1"], [20.1, 20.4])
    assert any("Ambient ignored" in n for n in lab.notes), lab.notes
    with pytest.raises(InputError, match=r"no column 'TC9'.*TC1, TC2, Ambient"):
        read_lab_csv(path, OUT, columns={"TC9": "z0"})
    with pytest.raises(InputError, match=r"'x5' is not an output.*allowed: z0, z1, tc1"):
        read_lab_csv(path, OUT, columns={"TC1": "x5"})
    with pytest.raises(InputError, match="--column TC1=OUTPUT"):
        read_lab_csv(path, OUT)


def test_a_time_column_of_any_name_is_mapped_onto_t(tmp_path: Path) -> None:
    path = write(tmp_path, "elapsed.csv", "Messzeit,TC1\n0,20.5\n1,21\n")
    lab = read_lab_csv(path, OUT, columns={"Messzeit": "t", "TC1": "z0"})
    np.testing.assert_array_equal(lab.table.t, [0, 1])
    with pytest.raises(InputError, match=r"the header must be 't,<face>,\.\.\.'"):
        read_lab_csv(path, OUT, columns={"TC1": "z0"})
    plain = write(tmp_path, "plain_t.csv", "t,TC1\n0,20.5\n1,21\n")  # a mapping of a time column it does not have
    with pytest.raises(InputError, match=r"--column Messzeit=t: the time column is 't', not 'Messzeit'"):
        read_lab_csv(plain, OUT, columns={"Messzeit": "t", "TC1": "z0"})
    clock = write(tmp_path, "mixed.csv", "t,z0\n09:14:01,20.5\n5,21\n")
    with pytest.raises(InputError, match=r"line 3: time '5' is not a clock time"):
        read_lab_csv(clock, OUT)


def test_stated_units_convert_and_a_conflict_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, "plain.csv", "t,z0\n0,293.65\n1,294.15\n")
    np.testing.assert_allclose(read_lab_csv(path, OUT, temperature_unit="K").table.mean_T["z0"], [20.5, 21.0])
    assert not read_lab_csv(path, OUT).temperature_stated
    np.testing.assert_allclose(read_lab_csv(path, OUT, time_unit="min").table.t, [0, 60])
    stated = write(tmp_path, "stated.csv", "t,z0\ns,K\n0,293.65\n1,294.15\n")
    with pytest.raises(InputError, match=r"column 'z0'.*the file says 'K', --temperature-unit says 'C'"):
        read_lab_csv(stated, OUT, temperature_unit="C")
    with pytest.raises(InputError, match=r"unknown time unit 'fortnight'"):
        read_lab_csv(write(tmp_path, "u.csv", "t,z0\nfortnight,°C\n0,1\n"), OUT)


@pytest.mark.parametrize(("content", "needles"), [
    ("t,z0\n0,20\n1,9.9e37\n2,21\n", ["line 3", "'z0'", "sentinel"]),
    ("t,z0\n0,20\n1,-9999\n2,21\n", ["line 3", "sentinel"]),
    ("t,z0\n0,20\n1,9999\n2,21\n", ["line 3", "sentinel"]),
    ("t,z0\n0,20\n1,1e155\n2,21\n", ["line 3", "sentinel"]),
    ("t,z0\n0,20\n1,-inf\n2,21\n", ["line 3", "'-inf' is not finite"]),
    ("t,z0\n0,20\n1,nan\n2,21\n", ["line 3", "'nan' is not finite"]),
    ("t,z0\n0,20\n1,-300\n2,21\n", ["line 3", "below absolute zero"]),
    ("t,z0\ns,K\n0,293\n1,-5\n", ["line 4", "-5 K is below absolute zero"]),
    ("t,z0\n0,20\n1,2000\n2,21\n", ["line 3", "plausible range [-200, 1500]", "--plausible"]),
    ("t,z0\n" + "".join(f"{i},{20 + 0.1 * i}\n" for i in range(8)).replace("5,20.5", "5,85.5"),
     ["line 7", "single outlier", "neighbours read 20.4 and 20.6"]),
])
def test_impossible_values_are_refused_naming_line_and_column(tmp_path: Path, content: str,
                                                              needles: list[str]) -> None:
    path = write(tmp_path, "bad.csv", content)
    with pytest.raises(InputError) as err:
        load_measurements(path, OUT)
    assert str(path) in str(err.value)
    for needle in needles:
        assert needle in str(err.value), str(err.value)


def test_the_plausible_range_is_configurable(tmp_path: Path) -> None:
    path = write(tmp_path, "furnace.csv", "t,z0\n0,1600\n1,1700\n")
    assert load_measurements(path, OUT, plausible=(0.0, 2000.0)).mean_T["z0"].tolist() == [1600.0, 1700.0]


def test_a_step_and_a_logger_quantum_are_not_outliers_but_a_spike_is() -> None:
    assert single_outlier(np.array([20.0, 20.0, 20.1, 20.0, 20.0, 20.0])) is None  # one quantum of 0.1 °C
    assert single_outlier(np.array([20.0, 20.0, 25.0, 25.1, 25.0, 25.2])) is None  # a step
    assert single_outlier(np.array([20.0, 20.0, 25.0, 20.0, 20.0, 20.1])) == 2


def test_kelvin_is_suspected_against_the_scene_start_only_when_far() -> None:
    assert kelvin_suspect(np.array([293.2, 294.0]), 20.0)
    assert not kelvin_suspect(np.array([20.2, 21.0]), 20.0)
    assert not kelvin_suspect(np.array([293.2, 294.0]), 290.0)  # a scene that starts hot


def test_an_overflow_code_in_python_measurements_never_reaches_the_optimiser() -> None:
    """Measurements built in Python (no CSV) with a 9.9e37 cell are refused by identify before any evaluation."""
    from aromm.core.observables import Observables
    from inverse.identification import identify

    class Never:  # a forward model that must not be evaluated
        outputs = ("z0",)
        parameter_names = frozenset({"fibre.k"})
        default_times = np.array([1.0])

        def simulate(self, *args: object, **kwargs: object) -> None:
            raise AssertionError("evaluated")

        simulate_batch = simulate

    data = Observables(np.array([1.0, 2.0, 3.0]), {"z0": np.array([20.0, 9.9e37, 21.0])}, source="lab")
    with pytest.raises(InputError, match=r"z0 at t = 2 s is 9.9e\+37, a logger's overflow code"):
        identify(Never(), data, {"fibre.k": (0.1, 1.0)})  # type: ignore[arg-type]
