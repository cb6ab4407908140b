"""The real rotary-actuator recordings read through the generic reader and the example map.

Skipped when ``<repo>/../shared`` is absent. No library code knows about this data set: only
``docs/examples/rotary_actuator_map.toml`` does.
"""

import re
from pathlib import Path

import numpy as np
import pytest

from leakdiag.cli.main import main
from leakdiag.io import RecordingError, build_column_map, read_recording
from leakdiag.io.errors import CutLastRowWarning

REPO = Path(__file__).resolve().parents[2]
MAP = REPO / "docs" / "examples" / "rotary_actuator_map.toml"
ADC_MAX = 2**14 - 1  # 14-bit ADC, data README


@pytest.fixture(scope="module")
def files(shared_dir):
    found = sorted((shared_dir / "realdata" / "rotary-actuators" / "Data").glob("*/*.txt"))
    if not found:
        pytest.skip("no rotary-actuator recordings found")
    # one per unit folder (the folder names contain spaces and parentheses)
    by_unit = {}
    for f in found:
        by_unit.setdefault(f.parent.name, f)
    return list(by_unit.values())


def test_reads_one_file_per_unit(files):
    assert any("(" in f.parent.name and " " in f.parent.name for f in files)
    for path in files:
        rec = read_recording(path, MAP)
        assert rec.n_samples == 3000
        assert rec.sample_rate == 1000.0
        assert rec.channel_names == ["p1", "p2", "angle"]
        assert rec.units == {"p1": "counts", "p2": "counts", "angle": "counts"}
        for name, values in rec.channels.items():
            assert 0 <= values.min() <= values.max() <= ADC_MAX, (path.name, name)
            assert np.all(values == np.round(values)), "counts are integers"
        # Time is a 1-based counter: t = counter / rate
        assert rec.start_time == pytest.approx(0.001)
        assert rec.duration == pytest.approx(3.0)
        assert rec.meta["source"] == str(path)


def test_values_match_a_plain_parse(files):
    path = files[0]
    lines = path.read_text().splitlines()
    header = lines[0].split("\t")
    i1, i2 = header.index("PG_1"), header.index("PG_2")
    pg1 = [float(line.split("\t")[i1]) for line in lines[1:]]
    pg2 = [float(line.split("\t")[i2]) for line in lines[1:]]
    rec = read_recording(path, MAP)
    assert rec["p1"].tolist() == pg1
    assert rec["p2"].tolist() == pg2


def test_command_line_specs_give_the_same_recording(files):
    path = files[-1]
    cmap = build_column_map(["p1=PG_1:counts", "p2=PG_2:counts", "angle=Angle:counts",
                             "time=Time:samples"], sample_rate_hz=1000)
    a, b = read_recording(path, cmap), read_recording(path, MAP)
    for k in a.channels:
        assert a[k].tobytes() == b[k].tobytes()
    assert (a.sample_rate, a.start_time) == (b.sample_rate, b.start_time)


def test_scaled_counts(files):
    # a made-up scale, only to check the arithmetic: (counts - 8192) * 1000 Pa
    cmap = build_column_map(["p1=PG_1:counts-8192*1000"], sample_rate_hz=1000)
    raw = read_recording(files[0], MAP)["p1"]
    rec = read_recording(files[0], cmap)
    assert rec.units == {"p1": "Pa"}
    np.testing.assert_array_equal(rec["p1"], (raw - 8192) * 1000)


def test_without_a_map_the_junk_text_columns_are_an_error(files):
    with pytest.raises(RecordingError, match=r"no column is named like a channel"):
        read_recording(files[0], sample_rate=1000)


def test_mapping_a_junk_text_column_is_an_error(files):
    cmap = build_column_map(["p1=F_Names"], sample_rate_hz=1000)
    with pytest.raises(RecordingError, match=r"channel 'p1' \(column 'F_Names'\) holds text, not "
                                             r"numbers: row 0 is 'Var_Accel1'"):
        read_recording(files[0], cmap)


def test_half_empty_numeric_junk_column_gives_first_nan_row(files):
    cmap = build_column_map(["p1=F_Values"], sample_rate_hz=1000)
    with pytest.raises(RecordingError, match=r"channel 'p1' \(column 'F_Values'\) has \d+ "
                       r"non-finite value\(s\); first NaN at row \d+"):
        read_recording(files[0], cmap)


def _damaged_copy(path, tmp_path, header=None, last=None):
    """A copy of a real file with its header and/or its last line (without newline) replaced."""
    lines = path.read_bytes().split(b"\n")
    assert lines[-1] == b"" and len(lines) == 3002  # header, 3000 rows, final newline
    if header is not None:
        lines[0] = header
    if last is not None:
        lines[-2:] = [last]
    copy = tmp_path / path.name  # same odd name (spaces), other folder
    copy.write_bytes(b"\n".join(lines))
    return copy


def test_truncated_last_line_of_a_real_file(files, tmp_path, capsys):
    path = files[0]
    original = read_recording(path, MAP)
    fields = path.read_bytes().split(b"\n")[-2].split(b"\t")
    assert len(fields) == 18 and len(fields[9]) >= 2  # PG_2 is the 10th field
    cut = b"\t".join(fields[:9] + [fields[9][:1]])  # "...\t5406" cut to "...\t5"
    copy = _damaged_copy(path, tmp_path, last=cut)
    message = (f"{copy}: row 2999 has 10 of 18 fields (truncated line?); column 'PG_2' "
               f"(channel 'p2') is missing or cut")
    with pytest.raises(RecordingError, match=re.escape(message) + "$"):
        read_recording(copy, MAP)
    assert main(["analyze", str(copy), "--map", str(MAP), "-m", "cross-correlation",
                 "-c", "p1,p2"]) == 2
    assert message in capsys.readouterr().err
    # the cut removes PG_1 and PG_2 entirely (7 fields: up to Temp_2)
    copy = _damaged_copy(path, tmp_path, last=b"\t".join(fields[:7]))
    with pytest.raises(RecordingError, match=re.escape(
            f"{copy}: row 2999 has 7 of 18 fields (truncated line?); columns 'PG_1' (channel "
            f"'p1'), 'PG_2' (channel 'p2') are missing or cut") + "$"):
        read_recording(copy, MAP)
    # only the final newline lost, or only the unread columns after Internal_Temp: read as is
    rec = read_recording(_damaged_copy(path, tmp_path, last=b"\t".join(fields)), MAP)
    for name in original.channels:
        assert rec[name].tobytes() == original[name].tobytes()
    for last in (b"\t".join(fields[:15]),):  # read, and said (session 28: a CLI audit)
        with pytest.warns(CutLastRowWarning, match="row 2999, has 15 of 18 fields"):
            rec = read_recording(_damaged_copy(path, tmp_path, last=last), MAP)
        for name in original.channels:
            assert rec[name].tobytes() == original[name].tobytes()


def test_repeated_column_name_in_a_real_header(files, tmp_path, capsys):
    path = files[0]
    header = path.read_bytes().split(b"\n")[0]
    assert header.split(b"\t")[7:9] == [b"Temp_3", b"PG_1"]
    copy = _damaged_copy(path, tmp_path, header=header.replace(b"Temp_3", b"PG_1"))
    message = (f"{copy}: column 'PG_1' (channel 'p1') appears 2 times in the header, at fields "
               f"8 and 9 (counting from 1); which one is meant cannot be told: rename the others")
    with pytest.raises(RecordingError, match=re.escape(message) + "$"):
        read_recording(copy, MAP)
    assert main(["analyze", str(copy), "--map", str(MAP), "-m", "cross-correlation",
                 "-c", "p1,p2"]) == 2
    assert message in capsys.readouterr().err
    # a repeated name that the map does not read is harmless
    copy = _damaged_copy(path, tmp_path, header=header.replace(b"Temp_2", b"Temp_3"))
    rec, original = read_recording(copy, MAP), read_recording(path, MAP)
    for name in original.channels:
        assert rec[name].tobytes() == original[name].tobytes()


def test_a_file_read_is_named_by_its_path_and_its_origin_kept(tmp_path):
    # decision audit 2026-11-27: a simulated recording written and read back kept
    # meta["source"] = "leakdiag.sim.simulate_eha", so the Python API's errors named the
    # simulator, not the file (the CLI renamed it itself)
    import leakdiag as ld

    path = ld.io.write_recording(ld.sim.simulate_vca(duration=2.0, leak_lpm=0.0, seed=1),
                                 tmp_path / "run.parquet")
    rec = ld.io.read_recording(path)
    assert rec.meta["source"] == str(path)
    assert rec.meta["origin"] == "leakdiag.sim.simulate_vca"


def test_a_row_without_a_field_before_the_pressures_is_refused(files, tmp_path):
    """A user-data audit (2026-11-29): data row 1500 of a real file without its Temp_3 field
    (17 of 18 fields) was read with PG_2's value as p1 and PG_3's as p2, because a short row
    that ends after every column read was taken to lack its last fields."""
    path = files[0]
    lines = path.read_bytes().split(b"\n")
    fields = lines[1501].split(b"\t")
    assert len(fields) == 18 and path.read_bytes().split(b"\n")[0].split(b"\t")[7] == b"Temp_3"
    lines[1501] = b"\t".join(fields[:7] + fields[8:])
    copy = tmp_path / path.name
    copy.write_bytes(b"\n".join(lines))
    with pytest.raises(RecordingError, match=re.escape(
            f"{copy}: row 1500 has 17 of 18 fields: a field is missing, and one missing before "
            "a column read shifts that column's value into another")):
        read_recording(copy, MAP)


def test_columns_of_channels_not_read_are_neither_required_nor_checked(files, tmp_path):
    """A user-data audit (2026-11-29): a real file whose Angle column was renamed was refused
    ("missing column 'Angle' for channel 'angle'") by commands that read only p1; and monitor
    and batch refused a file with a NaN in PG_2 that a p1 detector never reads (read whole
    through the map, every mapped channel checked), which detect judged."""
    from leakdiag.stream.files import open_recording

    path = files[0]
    lines = path.read_bytes().split(b"\n")
    copy = tmp_path / path.name
    copy.write_bytes(b"\n".join([lines[0].replace(b"Angle", b"Angle_raw"), *lines[1:]]))
    with pytest.raises(RecordingError, match="missing column 'Angle' for channel 'angle'"):
        read_recording(copy, MAP)
    rec = read_recording(copy, MAP, channels=["p1"])
    assert rec.channel_names == ["p1"]
    assert rec["p1"].tobytes() == read_recording(path, MAP)["p1"].tobytes()
    # a NaN in PG_2 (row 100): refused for p2, not for p1, by the chunked reader too
    header = lines[0].split(b"\t")
    fields = lines[101].split(b"\t")
    fields[header.index(b"PG_2")] = b""
    nan = tmp_path / "nan_pg2.txt"
    nan.write_bytes(b"\n".join([*lines[:101], b"\t".join(fields), *lines[102:]]))
    src, units = open_recording(nan, ["p1"], column_map=MAP)
    assert np.concatenate([c["p1"] for c in src]).tobytes() == \
        read_recording(path, MAP)["p1"].tobytes()
    with pytest.raises(RecordingError, match="channel 'p2' .*non-finite"):
        open_recording(nan, ["p1", "p2"], column_map=MAP)
