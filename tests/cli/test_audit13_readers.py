"""The readers of every command read a user's file by one set of rules (audit of users'
recordings, 2026-11-27, findings 10-12 and 9): the separator of a ``.csv``, a BOM on stdin, what
``#`` means, and what a time column in samples must hold. Through the CLI entry point."""

import re

import numpy as np
import pytest


def _lines(n=600, rate=1000.0):
    rng = np.random.default_rng(3)
    p1 = 1e7 + rng.normal(0, 1e5, n)
    p2 = 5e6 + rng.normal(0, 1e5, n)
    return ["time,p1,p2"] + [f"{k / rate:.3f},{a:.1f},{b:.1f}"
                             for k, (a, b) in enumerate(zip(p1, p2))]


def _summary(out):
    """monitor's summary line without the file name and the run time."""
    last = out.strip().splitlines()[-1]
    return last.split(": ", 1)[1].rsplit(", in ", 1)[0]


# --- finding 10: the separator of a .csv -----------------------------------------------------


@pytest.mark.parametrize("sep", [";", "\t", "|", " "])
def test_monitor_reads_the_csv_separators_that_analyze_reads(run_cli, tmp_path, sep):
    comma = tmp_path / "comma.csv"
    comma.write_text("\n".join(_lines()) + "\n")
    other = tmp_path / "other.csv"
    other.write_text("\n".join(line.replace(",", sep) for line in _lines()) + "\n")
    code, ref, err = run_cli(["monitor", str(comma), "-c", "p1", "-w", "100"])
    assert code == 0, err
    code, out, err = run_cli(["monitor", str(other), "-c", "p1", "-w", "100"])
    assert code == 0, err
    assert _summary(out) == _summary(ref)
    assert out.splitlines()[:-1] == ref.splitlines()[:-1]


# --- finding 12: a BOM on the stdin header ----------------------------------------------------


@pytest.mark.parametrize("first", ["time,p1,p2", "p1,p2"])
def test_monitor_stdin_strips_a_bom_from_the_header_as_a_file_read_does(run_cli, tmp_path, first):
    lines = _lines()
    if first == "p1,p2":
        lines = ["p1,p2"] + [line.split(",", 1)[1] for line in lines[1:]]
    extra = [] if first.startswith("time") else ["--sample-rate", "1000"]
    code, ref, err = run_cli(["monitor", "-", "-c", "p1", "-w", "100", *extra],
                             stdin="\n".join(lines) + "\n")
    assert code == 0, err
    code, out, err = run_cli(["monitor", "-", "-c", "p1", "-w", "100", *extra],
                             stdin="\ufeff" + "\n".join(lines) + "\n")
    assert code == 0, err
    assert out.splitlines()[:-1] == ref.splitlines()[:-1] and _summary(out) == _summary(ref)
    path = tmp_path / "bom.csv"
    path.write_text("\ufeff" + "\n".join(lines) + "\n", encoding="utf-8")
    code, out, err = run_cli(["monitor", str(path), "-c", "p1", "-w", "100", *extra])
    assert code == 0, err
    assert out.splitlines()[:-1] == ref.splitlines()[:-1] and _summary(out) == _summary(ref)


# --- finding 11: '#' is data in every reader --------------------------------------------------


def test_hash_is_data_in_every_command(run_cli, tmp_path):
    lines = _lines()
    note = tmp_path / "note.csv"
    note.write_text("\n".join(lines[:301] + ["# operator note"] + lines[301:]) + "\n")
    hint = ("has 1 of 3 fields (truncated line?); columns 'time' (time column), 'p1' (channel "
            "'p1') are missing or cut; it starts with '#', and leakdiag reads no comment lines")
    for args in (["monitor", str(note)], ["analyze", str(note), "-m", "autocorrelation"]):
        code, out, err = run_cli([*args, "-c", "p1", "-w", "100"])
        assert code != 0 and f"{note}: row 300 " in err and "it starts with '#'" in err, err
    code, out, err = run_cli(["monitor", "-", "-c", "p1", "-w", "100"], stdin=note.read_text())
    assert code != 0 and f"<stdin>: line 302 {hint}" in err, err
    na = tmp_path / "na.csv"
    t, _, p2 = lines[301].split(",")
    na.write_text("\n".join(lines[:301] + [f"{t},#N/A,{p2}"] + lines[302:]) + "\n")
    for args in (["monitor", str(na)], ["analyze", str(na), "-m", "autocorrelation"],
                 ["monitor", "-"]):
        code, out, err = run_cli([*args, "-c", "p1", "-w", "100"],
                                 stdin=na.read_text() if args[-1] == "-" else None)
        assert code != 0 and "'p1'" in err and "truncated" not in err, (args, err)


# --- finding 9: a sample counter counts samples; implausibly high rates are warned about ------


def _with_time(tmp_path, name, times):
    lines = _lines()
    path = tmp_path / name
    path.write_text("\n".join([lines[0]] + [f"{t},{line.split(',', 1)[1]}"
                                            for t, line in zip(times, lines[1:])]) + "\n")
    return str(path)


@pytest.mark.parametrize("command", ["analyze", "monitor"])
def test_time_unit_samples_needs_a_whole_number_counter_stepping_by_one(run_cli, tmp_path, command):
    n = len(_lines()) - 1
    args = ["-c", "p1", "-w", "100", "--time-unit", "samples", "--sample-rate", "1000"]
    if command == "analyze":
        args += ["-m", "autocorrelation"]
    seconds = _with_time(tmp_path, "s.csv", [f"{k / 1000:.3f}" for k in range(n)])
    code, out, err = run_cli([command, seconds, *args])
    assert code != 0 and (f"{seconds}: time column 'time' is declared a sample counter (time "
                          "unit 'samples'), but row 1 is 0.001, not a whole number") in err, err
    by10 = _with_time(tmp_path, "c10.csv", [str(10 * k) for k in range(n)])
    code, out, err = run_cli([command, by10, *args])
    assert code != 0 and ("but it steps by 10, not 1: at 1000 counts per second that is a "
                          "sample every 0.01 s, a rate of 100 Hz, not 1000 Hz") in err, err
    by1 = _with_time(tmp_path, "c1.csv", [str(k + 1) for k in range(n)])
    code, out, err = run_cli([command, by1, *args])
    assert code == 0 and "1000 Hz" in out, err


@pytest.mark.parametrize("unit,rate", [("ms", "1e+06"), ("us", "1e+09")])
@pytest.mark.parametrize("command", ["analyze", "monitor"])
def test_a_seconds_column_read_as_ms_or_us_is_warned_about(run_cli, tmp_path, command, unit, rate):
    n = len(_lines()) - 1
    path = _with_time(tmp_path, "s.csv", [f"{k / 1000:.3f}" for k in range(n)])
    extra = ["-m", "autocorrelation"] if command == "analyze" else []
    code, out, err = run_cli([command, path, "-c", "p1", "-w", "100", *extra])
    assert code == 0 and "high for actuator" not in err, err
    with pytest.warns(UserWarning, match=re.escape(
            f"{path}: sample rate {rate} Hz from the time column is high for actuator pressures "
            "(above 200000 Hz); is the time column in s rather than ms or us?")):
        code, out, err = run_cli([command, path, "-c", "p1", "-w", "100", "--time-unit", unit,
                                  *extra])
    assert code == 0, err
