"""Laboratory data and silent changes (issues 22 item 6, 23): the fault cases added to tests/fault_cases.py.

Same folder and runner (:mod:`fault_cases`); every refusal happens before any assembly.  The runner's stderr
is not a terminal that encodes °, ñ, ×: messages are checked in their ASCII spelling (aromm.cli.console).
The cases of issue 23's "Why": a logger overflow code ``9.9e37``, an open thermocouple ``-9999``, a value
≥ 1e155, times in ms against a 20 s scene, kelvin data, a one-row CSV, ``--order 100000``, ``--modes 5``,
``time_offset = -1000:1000``, bounds ``1e-300:1e300``; then each logger quirk read (exit 0, the conversion
printed) and each impossible value refused.
"""

from __future__ import annotations

from collections.abc import Callable

from fault_cases import CASES as BASE_CASES
from fault_cases import ID, SCENE, Case, K, Setup, text

M = ("--measurements", "m.csv")
IDM = (*ID[:3], "m.csv", *ID[4:])  # identify ... --measurements m.csv --model full --particles 2 --iterations 1
REDUCED = (*IDM[:5], "reduced", *IDM[6:])


def rows(f: Callable[[int], str], n: int = 20, header: str = "t,z0,z1\n") -> str:
    return header + "".join(f"{t:g},{f(t)}\n" for t in range(1, n + 1))


GOOD = rows(lambda t: f"{0.1 * t:g},{0.05 * t:g}")


def csv(content: str) -> tuple[Setup, ...]:
    return (text("m.csv", content),)


def cell(value: str) -> tuple[Setup, ...]:
    """GOOD with z0 at t = 5 replaced by ``value`` (file line 6)."""
    return csv(GOOD.replace("5,0.5,", f"5,{value},"))


SENSOR_SCENE = SCENE + '[outputs.tc1]\npoint = [1.155e-4, 1.155e-4, 1.155e-4]\n'
HIST = SCENE.replace("flux = 500.0", 'flux = "q.csv"')
T_HIST = SCENE.replace("T_ext = 0.0", 'T_ext = "text.csv"')
LAB = ("# logger DT85, serial 0042\n# exported 2026-11-30\nTime;TC1;TC2;Ambient\nmin;K;K;K\n"
       + "".join(f"{t / 60:.6g};{273.15 + 0.1 * t:.6g};{273.15 + 0.05 * t:.6g};293,15\n".replace(".", ",")
                 for t in range(1, 21)))

NEW: tuple[Case, ...] = (
    # issue 23, "Why": bad cells, units, one row, silent changes
    Case("identify-logger-overflow-9.9e37", (*IDM, *K), 2, ("m.csv", "line 6", "'z0'", "sentinel"), cell("9.9e37")),
    Case("identify-open-thermocouple-9999", (*IDM, *K), 2, ("m.csv", "line 6", "sentinel"), cell("-9999")),
    Case("identify-huge-value-1e155", (*IDM, *K), 2, ("m.csv", "line 6", "sentinel"), cell("1e155")),
    Case("identify-times-in-ms", (*IDM, *K), 2, ("m.csv", "past the end", "[time] end = 20 s", "--time-unit"),
         csv("t,z0,z1\n" + "".join(f"{1000 * t},{0.1 * t:g},{0.05 * t:g}\n" for t in range(1, 21)))),
    Case("identify-times-in-ms-reduced", (*REDUCED, *K), 2, ("m.csv", "past the end", "ms? min?"),
         csv("t,z0,z1\n" + "".join(f"{1000 * t},{0.1 * t:g},{0.05 * t:g}\n" for t in range(1, 21)))),
    Case("identify-kelvin-unstated", (*REDUCED, *K), 2, ("m.csv", "'z0'", "kelvin", "--temperature-unit K"),
         csv(rows(lambda t: f"{273.15 + 0.1 * t:g},{273.15 + 0.05 * t:g}"))),
    Case("identify-one-row-two-unknowns", (*IDM, *K, "--unknown", "fibre.c=1e5:1e7"), 2,
         ("m.csv", "too few rows", "1 row(s) x 2 column(s)", "at least 3"), csv("t,z0,z1\n5,0.5,0.25\n")),
    Case("identify-one-row-log-interval", (*IDM, *K), 0, (), csv("t,z0,z1\n5,0.5,0.25\n"), stdout=("(log)",)),
    Case("identify-time-offset-wider-than-experiment", (*ID, *K, "--unknown", "time_offset=-1000:1000"), 2,
         ("time_offset", "2000 s", "wider than the whole experiment", "end = 20 s")),
    Case("identify-bounds-600-decades", (*ID, "--unknown", "fibre.k=1e-300:1e300"), 2,
         ("--unknown", "fibre.k", "600 decades", "physical range")),
    Case("identify-bounds-9-decades", (*ID, "--unknown", "fibre.c=1e-2:1e7"), 2, ("--unknown", "9 decades")),
    Case("reduce-order-100000-stated", ("reduce", "scene.toml", "--order", "100000"), 0,
         ("warning", "order n~ = 100000 asked", "used", "N~ = 150020 modes asked")),
    Case("reduce-modes-5-stated", ("reduce", "scene.toml", "--modes", "5"), 0,
         ("warning", "order n~ = 200 asked", "19 vectors", "raise --modes")),
    # logger quirks read, the conversions said
    Case("identify-logger-export-read", (*IDM, *K, "--column", "TC1=z0", "--column", "TC2=z1"), 0,
         ("delimiter ';', decimal comma", "from min to s", "'TC1' converted from K to degC", "Ambient ignored",
          "'TC1' read as output 'z0'"), csv(LAB)),
    Case("identify-latin1-units-row", (*IDM, *K), 0, ("latin-1",),
         (lambda d: (d / "m.csv").write_bytes(("t,z0,z1\ns,°C,°C\n" + GOOD.split("\n", 1)[1]).encode("latin-1")),)),
    Case("identify-missing-cells-dropped", (*IDM, *K), 0, ("2 row(s) with missing values dropped", "line(s) 4, 6"),
         csv(GOOD.replace("3,0.3,", "3,,").replace("5,0.5,", "5,NA,"))),
    Case("identify-kelvin-stated", (*IDM, *K, "--temperature-unit", "K"), 0, ("converted from K to degC",),
         csv(rows(lambda t: f"{273.15 + 0.1 * t:.6g},{273.15 + 0.05 * t:.6g}"))),
    Case("identify-ms-stated", (*IDM, *K, "--time-unit", "ms"), 0, ("from ms to s",),
         csv("t,z0,z1\n" + "".join(f"{1000 * t},{0.1 * t:g},{0.05 * t:g}\n" for t in range(1, 21)))),
    Case("identify-sensor-column", ("identify", "sensor.toml", *M, *ID[4:], *K, "--column", "TC1=tc1"), 0,
         ("'TC1' read as output 'tc1'",), (text("sensor.toml", SENSOR_SCENE),
                                           text("m.csv", rows(lambda t: f"{0.1 * t:g}", header="t,TC1\n")))),
    # impossible values and bad options refused, before any build
    Case("identify-csv-nan", (*IDM, *K), 2, ("line 6", "'nan' is not finite"), cell("nan")),
    Case("identify-csv-fahrenheit", (*IDM, *K), 2, ("m.csv", "'z0'", "degrees Fahrenheit", "convert them"),
         csv(rows(lambda t: f"{32 + 0.18 * t:g},{32 + 0.09 * t:g}"))),
    Case("identify-csv-all-zero", (*IDM, *K), 2, ("m.csv", "every measured temperature is 0 ", "nothing to identify"),
         csv(rows(lambda t: "0,0"))),
    Case("identify-measurements-from-a-device", (*ID[:3], "/dev/zero", *ID[4:], *K), 2,
         ("/dev/zero", "not a regular file")),
    Case("identify-csv-inf", (*IDM, *K), 2, ("line 6", "'-inf' is not finite"), cell("-inf")),
    Case("identify-csv-below-absolute-zero", (*IDM, *K), 2, ("line 6", "below absolute zero"), cell("-300")),
    Case("identify-csv-negative-kelvin", (*IDM, *K), 2, ("line 3", "-5 K is below absolute zero"),
         csv("t,z0,z1\ns,K,K\n1,-5,273\n2,273,273\n")),
    Case("identify-csv-implausible", (*IDM, *K), 2, ("line 6", "plausible range [-200, 1500]", "--plausible"),
         cell("2000")),
    Case("identify-csv-implausible-own-range", (*IDM, *K, "--plausible", "0:1"), 2, ("line 12", "[0, 1] degC"),
         csv(GOOD)),
    Case("identify-plausible-syntax", (*ID, *K, "--plausible", "5:1"), 2, ("--plausible", "LOW < HIGH")),
    Case("identify-plausible-nan", (*ID, *K, "--plausible", "nan:1"), 2, ("--plausible", "finite")),
    Case("identify-csv-single-outlier", (*IDM, *K), 2, ("line 6", "single outlier", "0.4 and 0.6"), cell("35")),
    Case("identify-csv-time-unit", (*IDM, *K), 2, ("m.csv", "unknown time unit 'fortnight'", "min"),
         csv("t,z0,z1\nfortnight,°C,°C\n1,0.1,0.05\n2,0.2,0.1\n")),
    Case("identify-csv-temperature-unit", (*IDM, *K), 2, ("m.csv", "'z0'", "unknown temperature unit 'F'", "K"),
         csv("t,z0,z1\ns,F,F\n1,0.1,0.05\n2,0.2,0.1\n")),
    Case("identify-csv-unit-conflict", (*IDM, *K, "--temperature-unit", "C"), 2,
         ("'z0'", "the file says 'K'", "--temperature-unit says 'C'"),
         csv("t,z0,z1\ns,K,K\n1,273.2,273.1\n2,273.3,273.2\n")),
    Case("identify-csv-time-unit-conflict", (*IDM, *K, "--time-unit", "s"), 2, ("the file says times are in 'min'",),
         csv("t,z0,z1\nmin,°C,°C\n0.01,0.1,0.05\n0.02,0.2,0.1\n")),
    Case("identify-csv-header-and-units-row-disagree", (*IDM, *K), 2, ("line 2", "'min' disagrees", "'s'"),
         csv("t (s),z0,z1\nmin,°C,°C\n1,0.1,0.05\n2,0.2,0.1\n")),
    Case("identify-csv-only-comments", (*IDM, *K), 2, ("m.csv", "empty file", "comments"), csv("# nothing\n#\n")),
    Case("identify-csv-every-row-missing", (*IDM, *K), 2, ("m.csv", "every data row has a missing value"),
         csv("t,z0,z1\n1,,0.1\n2,NA,0.2\n")),
    Case("identify-csv-semicolon-fields", (*IDM, *K), 2, ("line 3", "2 fields, the header has 3"),
         csv("t;z0;z1\n1;0,1;0,05\n2;0,2\n")),
    Case("identify-csv-unmapped-column", (*IDM, *K), 2, ("'TC1' is not an output", "--column TC1=OUTPUT"),
         csv("t,TC1\n1,0.1\n2,0.2\n")),
    Case("identify-column-syntax", (*ID, *K, "--column", "TC1"), 2, ("--column", "FILE_COLUMN=OUTPUT")),
    Case("identify-column-mapped-twice", (*ID, *K, "--column", "a=z0", "--column", "a=z1"), 2,
         ("--column", "'a' is mapped twice")),
    Case("identify-column-not-in-file", (*IDM, *K, "--column", "TC9=z0"), 2, ("no column 'TC9'", "TC1"),
         csv("t,TC1\n1,0.1\n2,0.2\n")),
    Case("identify-column-not-an-output", (*IDM, *K, "--column", "TC1=x5"), 2, ("'x5' is not an output", "z0, z1"),
         csv("t,TC1\n1,0.1\n2,0.2\n")),
    Case("identify-column-two-onto-one", (*IDM, *K, "--column", "TC1=z0", "--column", "TC2=z0"), 2,
         ("'TC1' and 'TC2' are both mapped onto 'z0'",), csv("t,TC1,TC2\n1,0.1,0.1\n2,0.2,0.2\n")),
    Case("identify-time-unit-choice", (*ID, *K, "--time-unit", "fortnight"), 2, ("--time-unit", "'ms', 's'")),
    Case("identify-temperature-unit-choice", (*ID, *K, "--temperature-unit", "F"), 2, ("--temperature-unit",)),
    Case("identify-model-error-negative", (*ID, *K, "--model-error", "-0.1"), 2, ("--model-error", "0<=x<=1")),
    Case("identify-model-error-nan", (*ID, *K, "--model-error", "nan"), 2, ("--model-error", "finite")),
    # load histories read by the same reader
    Case("simulate-history-sentinel", ("simulate", "hist.toml"), 2, ("q.csv", "line 3", "sentinel"),
         (text("hist.toml", HIST), text("q.csv", "t,q\n0,500\n1,9.9e37\n2,500\n"))),
    Case("simulate-history-flux-in-celsius", ("simulate", "hist.toml"), 2, ("q.csv", "heat flux", "W/m2"),
         (text("hist.toml", HIST), text("q.csv", "t,q\ns,°C\n0,500\n2,500\n"))),
    Case("simulate-history-kelvin-below-zero", ("simulate", "hist.toml"), 2, ("text.csv", "below absolute zero"),
         (text("hist.toml", T_HIST), text("text.csv", "t,T\ns,K\n0,-3\n2,-3\n"))),
    Case("simulate-history-in-minutes-and-kelvin", ("simulate", "hist.toml"), 0,
         ("from min to s", "from K to degC"),
         (text("hist.toml", T_HIST), text("text.csv", "t,T\nmin,K\n0,273.15\n1,283.15\n"))),
)

CASES: tuple[Case, ...] = (*BASE_CASES, *NEW)
