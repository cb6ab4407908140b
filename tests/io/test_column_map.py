"""Column maps: TOML files, dicts, the command-line mini-syntax, and their errors."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.io import (
    ChannelSpec,
    ColumnMap,
    RecordingError,
    build_column_map,
    load_column_map,
    parse_column_spec,
)

TOML = """
[file]
separator = "\\t"
sample_rate_hz = 1000
time_column = "Time"
time_unit = "samples"

[channels.p1]
column = "PG_1"
unit = "counts"
gain = 0.5
offset = 8192

[channels.x]
column = "Pos"
unit = "mm"
"""


def test_load_toml(tmp_path):
    path = tmp_path / "map.toml"
    path.write_text(TOML)
    cmap = load_column_map(path)
    assert cmap.separator == "\t"
    assert cmap.sample_rate_hz == 1000.0
    assert (cmap.time_column, cmap.time_unit) == ("Time", "samples")
    assert cmap.channels == {
        "p1": ChannelSpec("PG_1", "counts", 0.5, 8192.0),
        "x": ChannelSpec("Pos", "mm"),
    }
    # to_dict round-trips
    assert load_column_map(cmap.to_dict()) == cmap
    assert load_column_map(str(path)) == cmap


def test_flat_dict_shorthand():
    cmap = load_column_map({"p1": "PG_1:psi", "p2": {"column": "PG_2", "unit": "bar"},
                            "u": ChannelSpec("Cmd", "mV")})
    assert cmap.channels["p1"] == ChannelSpec("PG_1", "psi")
    assert cmap.channels["p2"].unit == "bar"
    assert cmap.channels["u"].unit == "mV"


@pytest.mark.parametrize(
    "spec, expected",
    [
        ("p1=PG_1", ("p1", ChannelSpec("PG_1"))),
        ("p1=PG_1:psi", ("p1", ChannelSpec("PG_1", "psi"))),
        ("p1=PG_1:counts*0.5", ("p1", ChannelSpec("PG_1", "counts", 0.5))),
        ("p1=PG_1:counts-8192*0.5", ("p1", ChannelSpec("PG_1", "counts", 0.5, 8192.0))),
        ("p1=PG_1:counts+100*2e3", ("p1", ChannelSpec("PG_1", "counts", 2000.0, -100.0))),
        ("p1 = PG 1 : bar * 1.5", ("p1", ChannelSpec("PG 1", "bar", 1.5))),
        ("leak_flow=Q:L/min", ("leak_flow", ChannelSpec("Q", "L/min"))),
        ("leak_flow=Q:m^3/s", ("leak_flow", ChannelSpec("Q", "m^3/s"))),
        ("x=a:b:mm", ("x", ChannelSpec("a:b", "mm"))),  # column is up to the LAST colon
        ("p1=data(:,2)", ("p1", ChannelSpec("data(:,2)"))),  # colons in () belong to the name
        ("p1=S.v(:,2):bar*2", ("p1", ChannelSpec("S.v(:,2)", "bar", 2.0))),
        ("angle=Angle:counts*0.001->rad", ("angle", ChannelSpec("Angle", "counts", 0.001,
                                                                si_unit="rad"))),
        ("u=Cmd:V*-1", ("u", ChannelSpec("Cmd", "V", -1.0))),
        ("time=Time:samples", ("time", ChannelSpec("Time"))),
        ("time=t:ms", ("time", ChannelSpec("t", "ms"))),
    ],
)
def test_parse_column_spec(spec, expected):
    assert parse_column_spec(spec) == expected


@pytest.mark.parametrize(
    "spec, match",
    [
        ("PG_1", r"must look like CHANNEL=COLUMN"),
        ("1p=PG_1", r"channel name '1p' must be an identifier"),
        ("p1=:psi", r"empty column name"),
        ("p1=PG_1:psi**2", r"cannot parse 'psi\*\*2'"),
        ("p1=PG_1:atm", r"unknown unit 'atm'; known units: Pa, kPa, MPa, bar, psi"),
        ("p1=PG_1:counts*0", r"gain=0.0 must not be 0"),
        ("time=Time:bar", r"time column takes only a unit, one of s, ms, us, samples"),
        ("angle=A:counts*2->furlong", r"si_unit='furlong' must be one of"),
    ],
)
def test_parse_column_spec_errors(spec, match):
    with pytest.raises(RecordingError, match=match):
        parse_column_spec(spec)


def test_build_column_map_on_top_of_a_file(tmp_path):
    path = tmp_path / "map.toml"
    path.write_text(TOML)
    cmap = build_column_map(["x=Pos:in", "p2=PG_2:psi", "time=T:ms"], base=path,
                            sample_rate_hz=None, separator=",")
    assert cmap.channels["x"] == ChannelSpec("Pos", "in")          # replaced
    assert cmap.channels["p1"].gain == 0.5                           # kept
    assert cmap.channels["p2"] == ChannelSpec("PG_2", "psi")         # added
    assert (cmap.time_column, cmap.time_unit) == ("T", "ms")
    assert cmap.separator == ","                                     # overridden
    assert cmap.sample_rate_hz == 1000.0                             # None ignored
    only_column = build_column_map(["time=Clock"], base=path)
    assert (only_column.time_column, only_column.time_unit) == ("Clock", "samples")


def test_build_column_map_unknown_option():
    with pytest.raises(RecordingError, match=r"unknown file option\(s\) \['rate'\]"):
        build_column_map([], rate=1000)


@pytest.mark.parametrize(
    "text, match",
    [
        ("[file]\nsample_rate = 1000\n", r"\[file\]: unknown key\(s\) \['sample_rate'\]; allowed"),
        ("[channels.p1]\ncolumn = 'A'\nunits = 'bar'\n",
         r"channel 'p1': unknown key\(s\) \['units'\]"),
        ("[channels.p1]\nunit = 'bar'\n", r"channel 'p1': missing key 'column'"),
        ("[channels.p1]\ncolumn = 'A'\nunit = 'atm'\n", r"unknown unit 'atm'"),
        ("[file]\ntime_unit = 'h'\n", r"time_unit='h' must be one of s, ms, us, samples"),
        ("[file]\nsample_rate_hz = -5\n", r"sample_rate_hz=-5 must be > 0"),
        ("[channels.time]\ncolumn = 'T'\n", r"'time' is not a channel"),
        ("[channels\n", r"not a valid TOML column map"),
    ],
)
def test_toml_errors_name_the_map_file(tmp_path, text, match):
    path = tmp_path / "bad map.toml"
    path.write_text(text)
    with pytest.raises(RecordingError, match=match) as info:
        load_column_map(path)
    assert str(path) in str(info.value)


def test_missing_map_file(tmp_path):
    with pytest.raises(RecordingError, match=r"nope.toml: column map file not found"):
        load_column_map(tmp_path / "nope.toml")


def test_bad_map_type():
    with pytest.raises(TypeError, match="column map must be"):
        load_column_map(42)
    with pytest.raises(RecordingError, match="must be a ChannelSpec"):
        ColumnMap({"p1": "PG_1"})


_units = st.sampled_from(["Pa", "kPa", "psi", "bar", "counts"])
_numbers = st.floats(1e-6, 1e6, allow_nan=False).map(lambda v: float(f"{v:.6g}"))


@settings(max_examples=40, deadline=None)
@given(column=st.from_regex(r"[A-Za-z][A-Za-z0-9_ ]{0,10}[A-Za-z0-9]", fullmatch=True),
       unit=_units, gain=_numbers, offset=st.one_of(st.just(0.0), _numbers))
def test_spec_syntax_round_trip(column, unit, gain, offset):
    spec = f"p1={column}:{unit}" + (f"-{offset!r}" if offset else "") + f"*{gain!r}"
    name, parsed = parse_column_spec(spec)
    assert name == "p1"
    assert parsed == ChannelSpec(column, unit, gain, offset)


def test_non_numeric_file_option(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text("[file]\nsample_rate_hz = 'fast'\n")
    with pytest.raises(RecordingError, match=r"\[file\]: sample_rate_hz='fast' must be a number"):
        load_column_map(path)


def test_a_map_states_the_rig_and_load_of_a_file_without_metadata(tmp_path):
    """A CSV keeps no metadata: the map's [file] system/load become the recording's meta, so
    detectors can check them (an audit found a VCA detector judging a plain-CSV healthy EHA
    run LEAK, unchecked)."""
    import numpy as np

    from leakdiag.io import read_recording, write_recording
    from leakdiag.io.recording import Recording

    rec = Recording({"p1": np.arange(5.0) + 1e6, "p2": np.arange(5.0)}, 10.0,
                    meta={"system": "vca", "load": "spring"})
    csv = write_recording(rec, tmp_path / "r.csv")
    base = {"channels": {"p1": "p1", "p2": "p2"}}
    plain = read_recording(csv, base)
    assert "system" not in plain.meta and "load" not in plain.meta  # the CSV lost them
    cmap = load_column_map({"file": {"system": "VCA", "load": " Spring "}, **base})
    assert (cmap.system, cmap.load) == ("vca", "spring")
    assert load_column_map(cmap.to_dict()) == cmap
    got = read_recording(csv, cmap)
    assert (got.meta["system"], got.meta["load"]) == ("vca", "spring")
    # a file whose own metadata say otherwise is refused, not overridden
    pq = write_recording(rec, tmp_path / "r.parquet")
    with pytest.raises(RecordingError, match=r"r.parquet: the column map says rig 'eha', the "
                                             r"file's own metadata say 'vca': fix the map"):
        read_recording(pq, {"file": {"system": "eha"}, **base})
    assert read_recording(pq, {"file": {"load": "spring"}, **base}).meta["load"] == "spring"
    with pytest.raises(RecordingError, match=r"system='rig' must be one of vca, eha"):
        load_column_map({"file": {"system": "rig"}, **base})
    with pytest.raises(RecordingError, match=r"load='' must be a non-empty name"):
        load_column_map({"file": {"load": ""}, **base})
