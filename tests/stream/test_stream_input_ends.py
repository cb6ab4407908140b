"""How a stream's input ends, through ``leakdiag monitor``: a followed file's last line without
its newline (left out with a warning), a line written in pieces, header-only stdin and followed
files, a time column too short for a rate, and HDF5 datasets of different lengths (refused
before the first chunk, in the words of ``read_recording``)."""

import json
import re
import types

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from leakdiag.cli.main import cli
from leakdiag.io import read_recording
from leakdiag.stream.live import IncompleteLineWarning

WARN_CUT = ("{path}: line {n} is incomplete: no newline after {t} s without new data (a write cut "
            "short, or a writer that stopped mid-line?): {text} was left out, not read as a "
            "sample")


def _lines(n, start=0):
    """``n`` CSV lines ``time,p1`` at 1 kHz, p1 a sine (never constant)."""
    return "".join(f"{k / 1000:.3f},{1e5 + 1e3 * np.sin(0.7 * k):.6f}\n"
                   for k in range(start, start + n))


def _events(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def _same_events(a, b):
    """Equal windows; values to 1e-12 relative (one line per chunk against one chunk)."""
    assert [(e["time"], e["window"]) for e in a] == [(e["time"], e["window"]) for e in b]
    np.testing.assert_allclose([e["value"] for e in a], [e["value"] for e in b], rtol=1e-12)


def _monitor(*args, **kw):
    return CliRunner().invoke(cli, ["monitor", *map(str, args)], **kw)


# ------------------------------------------------------------ finding 3: a cut last line
def test_follow_leaves_out_a_last_line_without_newline_with_a_warning(tmp_path):
    whole, part = tmp_path / "whole.csv", tmp_path / "part.csv"
    whole.write_text("time,p1\n" + _lines(200))
    part.write_text("time,p1\n" + _lines(200) + "0.200,86")  # 0.200,100523.1... cut short
    ev_whole, ev_part = tmp_path / "whole.jsonl", tmp_path / "part.jsonl"
    opts = ["-c", "p1", "-w", "67", "--overlap", "0"]  # a 201st sample would end a window
    r = _monitor(whole, *opts, "--events", ev_whole)
    assert r.exit_code == 0, r.output
    with pytest.warns(IncompleteLineWarning) as caught:
        r = _monitor(part, "--follow", "--idle-timeout", "0.1", *opts, "--events", ev_part)
    assert r.exit_code == 0, r.output
    assert [str(w.message) for w in caught] == [
        WARN_CUT.format(path=part, n=202, t="0.1", text="'0.200,86'")]
    assert f"{part}: 200 samples at 1000 Hz, 2 windows" in r.output
    _same_events(_events(ev_part), _events(ev_whole))  # the cut sample was not judged


def test_follow_names_a_long_cut_line_by_its_start_and_length(tmp_path):
    path = tmp_path / "part.csv"
    cut = "0.200," + "1" * 100
    path.write_text("time,p1\n" + _lines(200) + cut)
    with pytest.warns(IncompleteLineWarning) as caught:
        r = _monitor(path, "--follow", "--idle-timeout", "0.1", "-c", "p1", "-w", "50", "-q")
    assert r.exit_code == 0, r.output
    assert [str(w.message) for w in caught] == [WARN_CUT.format(
        path=path, n=202, t="0.1", text=f"{cut[:80]!r}... (106 characters)")]


def test_follow_reads_a_line_written_in_pieces_whose_pauses_add_up_past_the_timeout(
        tmp_path, monkeypatch):
    """Each piece of a line starts the idle time again: four pauses of 3 polls (0.15 s) each
    add up to more than --idle-timeout 0.25 (5 polls), none lasts it. The clock is the count
    of the reader's sleeps, not the wall clock."""
    import leakdiag.stream.live as live

    path = tmp_path / "live.csv"
    path.write_text("time,p1\n" + _lines(100))
    pieces = iter(["0.1", "00,12", "345.6", "78\n"])
    polls = [0]

    def sleep(_s):  # a writer that adds a piece of the last line every third poll
        polls[0] += 1
        if polls[0] % 3 == 0:
            piece = next(pieces, None)
            if piece is not None:
                with open(path, "a") as f:
                    f.write(piece)

    monkeypatch.setattr(live, "time", types.SimpleNamespace(sleep=sleep))
    ev = tmp_path / "ev.jsonl"
    r = _monitor(path, "--follow", "--idle-timeout", "0.25", "-c", "p1", "-w", "101",
                 "--overlap", "0", "--events", ev)
    assert r.exit_code == 0, r.output
    assert f"{path}: 101 samples at 1000 Hz, 1 windows" in r.output
    whole = tmp_path / "whole.csv"
    whole.write_text("time,p1\n" + _lines(100) + "0.100,12345.678\n")
    ev_whole = tmp_path / "whole.jsonl"
    assert _monitor(whole, "-c", "p1", "-w", "101", "--overlap", "0", "--events",
                    ev_whole).exit_code == 0
    _same_events(_events(ev), _events(ev_whole))


def test_follow_refuses_a_header_without_newline(tmp_path):
    path = tmp_path / "live.csv"
    path.write_text("time,p1")
    r = _monitor(path, "--follow", "--idle-timeout", "0.1", "-c", "p1", "-q")
    assert r.exit_code != 0
    assert str(r.exception) == (
        f"{path}: line 1 (the header) is incomplete: no newline after 0.1 s without new data (a "
        "write cut short, or a writer that stopped mid-line?): 'time,p1'; no data lines")


def test_stdin_reads_a_last_line_without_newline_as_the_end_of_input():
    """Decided: on stdin the end of input ends the last line (as for a file's last row)."""
    text = "time,p1\n" + _lines(200) + "0.200,86"
    r = _monitor("-", "-c", "p1", "-w", "67", "--overlap", "0", input=text)
    assert r.exit_code == 0, r.output
    assert "<stdin>: 201 samples at 1000 Hz, 3 windows" in r.output


# ------------------------------------------------------------ finding 6: header only
@pytest.mark.parametrize("text,rate", [("time,p1\n", None), ("time,p1\n\n \n", None),
                                       ("p1\n", "100")])
def test_stdin_with_a_header_only_says_so(text, rate):
    r = _monitor("-", "-c", "p1", "-q", *(["--sample-rate", rate] if rate else []), input=text)
    assert r.exit_code != 0
    assert str(r.exception) == "<stdin>: header only, no data lines"


def test_follow_of_a_header_only_file_says_so(tmp_path):
    path = tmp_path / "hdr.csv"
    path.write_text("time,p1\n")
    r = _monitor(path, "--follow", "--idle-timeout", "0.1", "-c", "p1", "-q")
    assert r.exit_code != 0
    assert str(r.exception) == f"{path}: header only, no data lines"
    path.write_text("time,p1\n0.000,8")  # its only data line cut short: left out, then refused
    with pytest.warns(IncompleteLineWarning) as caught:
        r = _monitor(path, "--follow", "--idle-timeout", "0.1", "-c", "p1", "-q")
    assert [str(w.message) for w in caught] == [
        WARN_CUT.format(path=path, n=2, t="0.1", text="'0.000,8'")]
    assert str(r.exception) == f"{path}: header only, no data lines"


@pytest.mark.parametrize("suffix", ["-", ".csv", ".parquet"])
def test_one_time_value_is_too_few_for_a_rate_not_a_missing_time_column(tmp_path, suffix):
    """The stream said "no 'time' column and no sample rate" for a time column of one value;
    now it says what read_recording says (monitor and detect alike)."""
    df = pd.DataFrame({"time": [0.0], "p1": [1.0]})
    if suffix == "-":
        r, source = _monitor("-", "-c", "p1", "-q", input="time,p1\n0,1\n"), "<stdin>"
    else:
        path = tmp_path / f"one{suffix}"
        df.to_csv(path, index=False) if suffix == ".csv" else df.to_parquet(path)
        r, source = _monitor(path, "-c", "p1", "-q"), str(path)
        with pytest.raises(ValueError) as io_exc:
            read_recording(path)
        assert str(io_exc.value) == str(r.exception)
    assert r.exit_code != 0
    assert str(r.exception) == f"{source}: column 'time' has 1 sample(s); need at least 2"


# ------------------------------------------------------------ finding 4: HDF5 lengths
@pytest.mark.parametrize("cut,lengths", [
    ("time", "time column 'time'=300, p1=1000, p2=1000"),
    ("p2", "time column 'time'=1000, p1=1000, p2=700"),
    ("p1", "time column 'time'=1000, p1=700, p2=1000"),
])
def test_hdf5_datasets_of_different_lengths_are_refused_before_any_window(tmp_path, cut,
                                                                           lengths):
    import h5py

    rng = np.random.default_rng(0)
    cols = {"time": np.arange(1000) / 1000.0, "p1": rng.normal(size=1000),
            "p2": rng.normal(size=1000)}
    path = tmp_path / f"short_{cut}.h5"
    with h5py.File(path, "w") as f:  # another program's layout: datasets at the root
        for name, values in cols.items():
            f[name] = values[:{"time": 300}.get(cut, 700)] if name == cut else values
    ev = tmp_path / "ev.jsonl"
    r = _monitor(path, "-m", "cross-correlation", "-c", "p1,p2", "-w", "100", "--chunk", "256",
                 "--events", ev)
    assert r.exit_code != 0
    assert str(r.exception) == f"{path}: channels have different lengths ({lengths})"
    assert not ev.exists()  # refused when opened, not after windows were emitted
    with pytest.raises(ValueError) as io_exc:  # what detect and analyze read it with
        read_recording(path)
    assert str(io_exc.value) == str(r.exception)


def test_hdf5_leakdiag_layout_with_a_short_channel_is_refused(tmp_path):
    import h5py

    from leakdiag.io import Recording, write_recording

    rng = np.random.default_rng(1)
    path = tmp_path / "r.h5"
    write_recording(Recording({"p1": rng.normal(size=1000), "p2": rng.normal(size=1000)},
                              1000.0), path)
    with h5py.File(path, "a") as f:
        p2 = f["channels/p2"][:600]
        del f["channels/p2"]
        f["channels/p2"] = p2
    r = _monitor(path, "-c", "p1", "-w", "100", "-q")  # p2 not read: its length does not matter
    assert r.exit_code == 0, r.output
    r = _monitor(path, "-m", "cross-correlation", "-c", "p1,p2", "-w", "100", "-q")
    assert r.exit_code != 0
    assert re.fullmatch(re.escape(f"{path}: channels have different lengths (time column "
                                  "'time'=1000, p1=1000, p2=600)"), str(r.exception))
