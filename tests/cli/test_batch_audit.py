"""``leakdiag batch`` (and ``monitor``, ``detect`` where they share it) after the batch/store
audit of 2026-11-27: --store values that cannot be a store (finding 10), an actuator of two rigs
(3), duplicate detector names (9), a glob that covers --out (11), detector rows not judged (8),
units checked like detect and unchecked rig/load said once per file (7)."""

import os
import sqlite3

import numpy as np
import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main
from leakdiag.io import write_recording
from leakdiag.io.recording import Recording
from leakdiag.sim import simulate_vca
from leakdiag.store import EventStore


def _run(args, cwd=None):
    """``leakdiag ARGS`` through the entry point: exit code, stdout, stderr."""
    old = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with CliRunner().isolation() as (out, err, _):
            code = main([str(a) for a in args])
            return code, out.getvalue().decode(), err.getvalue().decode()
    finally:
        os.chdir(old)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """A detector fitted with ``leakdiag fit`` on two healthy 20-s VCA runs (acf-p1, Pa, rig
    vca, load none) and a 30-s leaking VCA recording."""
    d = tmp_path_factory.mktemp("batchaudit")
    h = [write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=s),
                         d / f"h{s}.parquet") for s in (1, 2)]
    code, out, err = _run(["fit", "--healthy", h[0], "--healthy", h[1], "-m", "acf-p1",
                           "--false-alarm-rate", "100", "--no-progress", "-o",
                           d / "det.joblib"])
    assert code == 0, err
    leak = simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=3)
    (d / "rigL").mkdir()
    write_recording(leak, d / "rigL" / "leak.parquet")
    (d / "job.toml").write_text('[[detector]]\nname = "acf"\npath = "det.joblib"\n')
    return {"dir": d, "det": d / "det.joblib", "leak": leak,
            "leak_path": d / "rigL" / "leak.parquet"}


def _batch(case, inputs, tmp_path, *extra, job=None):
    return _run(["batch", *inputs, "--config", job or case["dir"] / "job.toml", "-o",
                 tmp_path / "res", "--scheduler", "serial", "--no-progress", *extra])


def test_batch_and_monitor_refuse_a_recording_in_other_units(case, tmp_path):
    """Finding 7: a detector fitted on Pa judged a recording in counts (a column map's unit,
    or a Parquet file's header) in batch and monitor; detect refused it."""
    det = case["det"]
    df = case["leak"].to_pandas()[["time", "p1", "p2"]]
    df.to_csv(tmp_path / "run.csv", index=False)
    (tmp_path / "cmap.toml").write_text('[channels.p1]\ncolumn = "p1"\nunit = "counts"\n')
    counts = Recording({"p1": case["leak"]["p1"], "p2": case["leak"]["p2"]}, 1000.0,
                       units={"p1": "counts", "p2": "counts"}, meta={"system": "vca"})
    write_recording(counts, tmp_path / "counts.parquet")
    job = tmp_path / "job.toml"
    job.write_text(f'[job]\ncolumn_map = "cmap.toml"\n[[detector]]\nname = "acf"\n'
                   f'path = "{det}"\n')
    code, out, err = _batch(case, [tmp_path / "run.csv"], tmp_path, job=job)
    assert code == 1
    assert f"  error: run.csv: {tmp_path / 'run.csv'}: channel 'p1' is in 'counts', but " \
           f"{det} was fitted on 'Pa'" in err
    code, out, err = _batch(case, [tmp_path / "counts.parquet"], tmp_path / "b")
    assert code == 1
    assert f"  error: counts.parquet: {tmp_path / 'counts.parquet'}: channel 'p1' is in " \
           f"'counts', but {det} was fitted on 'Pa'" in err
    for args in (["monitor", tmp_path / "run.csv", "--map", tmp_path / "cmap.toml"],
                 ["monitor", tmp_path / "counts.parquet"]):
        code, out, err = _run([*args, "--detector", det, "-q"])
        assert code == 2 and f"channel 'p1' is in 'counts', but {det} was fitted on 'Pa'" \
            in err



def test_the_hdf5_units_batch_and_monitor_read_are_leakdiag_s_header_only(case, tmp_path):
    """Review item 7: batch and monitor read a file's units with ``leakdiag.io.recording_units``
    (one shared opening, ``stream.files.open_recording``). A leakdiag HDF5 file in counts is
    refused against a detector fitted on Pa, as detect refuses it; an HDF5 file that another
    program wrote claims no units, even with a top-level ``units`` attribute (it was read as
    leakdiag's: batch and monitor refused the file in Pa that detect judged)."""
    import json

    import h5py

    det = case["det"]
    counts = Recording({"p1": case["leak"]["p1"], "p2": case["leak"]["p2"]}, 1000.0,
                       units={"p1": "counts", "p2": "counts"}, meta={"system": "vca",
                                                                      "load": "none"})
    mine = write_recording(counts, tmp_path / "rigH" / "counts.h5")
    daq = tmp_path / "rigD" / "daq.h5"
    daq.parent.mkdir()
    with h5py.File(daq, "w") as f:  # samples in Pa, a DAQ program's own attributes
        f["time"] = case["leak"].time
        f["p1"] = case["leak"]["p1"]
        f["p2"] = case["leak"]["p2"]
        f.attrs["units"] = json.dumps({"p1": "counts", "p2": "counts"})
    refused = f"channel 'p1' is in 'counts', but {det} was fitted on 'Pa'"
    code, out, err = _batch(case, [mine, daq], tmp_path)
    assert code == 1
    assert [ln for ln in err.splitlines() if ln.startswith("  error:")] == [
        f"  error: counts.h5: {mine}: {refused}"]
    for cmd in ("monitor", "detect"):
        code, out, err = _run([cmd, mine, "--detector", det])
        assert code == 2 and refused in err, (cmd, err)
        code, out, err = _run([cmd, daq, "--detector", det])
        assert code == 0 and "counts" not in err, (cmd, err)

def _states_no(err):
    return [ln for ln in err.splitlines() if "states no" in ln]


def test_batch_says_once_per_file_what_its_metadata_leave_unchecked(case, tmp_path):
    """Finding 7: detect says that a plain CSV states no rig and no load, so they were not
    checked; batch said nothing. Two detectors, one line per file; monitor says it too.
    Review item 6: the three commands say it in one line built by one function
    (``unchecked_note``), only the advice differs (monitor and detect printed one line per
    property, batch one combined line)."""
    df = case["leak"].to_pandas()[["time", "p1", "p2"]]
    plain = tmp_path / "rigC" / "plain.csv"
    plain.parent.mkdir()
    df.to_csv(plain, index=False)
    det = case["det"]
    job = tmp_path / "job.toml"
    job.write_text(f'[[detector]]\nname = "a"\npath = "{det}"\n'
                   f'[[detector]]\nname = "b"\npath = "{det}"\n')
    code, out, err = _batch(case, [plain, case["leak_path"]], tmp_path, job=job)
    assert code == 0, err
    said = (f"leakdiag: warning: {plain} states no rig and no load and no machine unit in its "
            f"metadata, so it was not checked against the rig 'vca' and the load 'none' and the "
            f"machine unit 'nominal' of {det} (another rig or load or machine unit can look like "
            "a leak: state them as system and load and machine in the [file] table of ")
    assert _states_no(err) == [said + "the job's column map, or in the file's metadata)"]
    for args in (["monitor", plain, "--detector", det, "-q"],
                 ["detect", plain, "--detector", det, "--no-progress"]):
        code, out, err = _run(args)
        assert code == 0, err
        assert _states_no(err) == [said + "a --map, or in the file's metadata)"], args[0]


def test_a_detector_row_not_judged_is_said_counted_and_exits_1(case, tmp_path):
    """Finding 8: a recording the detector could not judge (4 s, shorter than its 5-s
    burn-in): batch printed '0 error(s)' and exited 0."""
    short = tmp_path / "rigS" / "short.parquet"
    short.parent.mkdir()
    write_recording(case["leak"].slice_time(0.0, 4.0), short)
    code, out, err = _batch(case, [short, case["leak_path"]], tmp_path)
    assert code == 1
    assert "2 recording(s): 2 run, 0 already done, 0 error(s) in this run; 2 current row(s) " \
           "for job" in out and f"in {tmp_path / 'res'}, 1 of them not judged" in out
    assert f"  not judged: short.parquet: acf: predict: {short}: too short to judge: 4 s " \
           "leaves no complete window of the feature after the 5-s burn-in" in err
    code, out, err = _batch(case, [case["leak_path"]], tmp_path)
    assert code == 0 and "0 of them not judged" in out and "not judged:" not in err


def test_two_detectors_of_one_name_are_refused_naming_both(case, tmp_path):
    """Finding 9: their rows could not be told apart and their store keys collided."""
    job = tmp_path / "job.toml"
    det = case["det"]
    job.write_text(f'[[detector]]\nname = "det"\npath = "{det}"\n'
                   f'[[detector]]\nname = "det"\npath = "{det}"\n')
    code, out, err = _batch(case, [case["leak_path"]], tmp_path, job=job)
    assert code == 2
    assert err == (f"leakdiag: error: {job}: [[detector]] #1 (path = '{det}') and "
                   f"[[detector]] #2 (path = '{det}') have the same detector name 'det': "
                   "their rows and stored runs could not be told apart; give each "
                   "[[detector]] its own name = \"...\" (a --detector file is named after "
                   "its file stem)\n")
    job.write_text(f'[[detector]]\npath = "{det}"\n')  # named 'det' after its stem
    code, out, err = _batch(case, [case["leak_path"]], tmp_path, "--detector", det, job=job)
    assert code == 2 and f"[[detector]] #1 (path = '{det}') and --detector {det} have the " \
                         "same detector name 'det'" in err
    assert not (tmp_path / "res").exists()


def test_a_feature_given_twice_is_refused_naming_the_entries(case, tmp_path):
    """Two [[analysis]] entries (or one sweep) that make the same feature gave two result rows
    of one name and one store key; refused before any work, naming the entries."""
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nlag = [1, 2]\n'
                   '[[analysis]]\nmethod = "autocorrelation"\nchannels = "p1"\nlag = 2\n')
    code, out, err = _batch(case, [case["leak_path"]], tmp_path, job=job)
    assert code == 2
    assert err == (f"leakdiag: error: {job}: [[analysis]] #2 repeats [[analysis]] #1: "
                   "autocorrelation p1 2 N=200 5% would be computed twice, with two result "
                   "rows of one name; give each setting once\n")
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nlag = [3, 3]\n')
    code, out, err = _batch(case, [case["leak_path"]], tmp_path, job=job)
    assert code == 2 and f"{job}: [[analysis]] #1 repeats a setting of its own: " \
                         "autocorrelation p1 3 N=200 5%" in err
    assert not (tmp_path / "res").exists()
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nlag = [1, 2]\n'
                   '[[analysis]]\nmethod = "autocorrelation"\nchannels = "p2"\nlag = 2\n')
    code, out, err = _batch(case, [case["leak_path"]], tmp_path, job=job)
    assert code == 0, err  # other channels: another feature


@pytest.mark.parametrize("store, why", [
    ("", "--store needs a file path or a database URL, got ''"),
    (" ", "--store needs a file path or a database URL, got ' '"),  # review item 10: "''"
    ("sqlite:///", "--store sqlite:///: an in-memory SQLite database ends with the connection "
                   "that made it: nothing would be kept, and every other connection (the page, "
                   "another command) sees an empty one; give a file, e.g. --store events.db"),
    ("sqlite:/x.db", "--store sqlite:/x.db: looks like a database URL, but a URL needs '//' "
                     "after 'sqlite:' (sqlite:///events.db is the file events.db, "
                     "sqlite:////data/events.db an absolute path); for a file of this name "
                     "write ./sqlite:/x.db"),
])
def test_store_values_that_cannot_be_a_store_are_refused_before_the_work(case, tmp_path,
                                                                         store, why):
    """Finding 10: 'sqlite:///' made batch do all the work, then crash ("no such table:
    runs"), detect write into a vanishing database and monitor say "empty database"; '' was
    ignored by batch and detect; 'sqlite:/x.db' became a file 'sqlite%3A/x.db'."""
    code, out, err = _batch(case, [case["leak_path"]], tmp_path, "--store", store)
    assert (code, out, err) == (2, "", f"leakdiag: error: {why}\n")
    assert not (tmp_path / "res").exists()
    code, out, err = _run(["detect", case["leak_path"], "--detector", case["det"], "--store",
                           store], cwd=tmp_path)
    assert code == 2 and out == "" and err.endswith(f"leakdiag: error: {why}\n")
    code, out, err = _run(["monitor", case["leak_path"], "--detector", case["det"],
                           "--store", store], cwd=tmp_path)
    assert code == 2 and out == "" and err.endswith(f"leakdiag: error: {why}\n")
    assert sorted(os.listdir(tmp_path)) == []  # no file of any name


def test_a_glob_that_covers_out_does_not_read_batch_s_results(case, tmp_path):
    """Finding 11: 'rec/**/*.parquet' with -o rec/results.parquet read the first run's result
    files as recordings (error rows "missing channel(s) ['p1']", exit 1)."""
    rec = tmp_path / "rec"
    (rec / "rigL").mkdir(parents=True)
    write_recording(case["leak"], rec / "rigL" / "leak.parquet")
    args = ["batch", rec / "**" / "*.parquet", "--config", case["dir"] / "job.toml", "-o",
            rec / "results.parquet", "--scheduler", "serial", "--no-progress"]
    code, out, err = _run(args)
    assert code == 0 and out.startswith("1 recording(s): 1 run,") and "note" not in err
    code, out, err = _run(args)
    assert code == 0, err
    assert out.startswith("1 recording(s): 0 run, 1 already done, 0 error(s) in this run; 1 "
                          "current row(s)")
    assert f"leakdiag: note: 1 file(s) that the inputs match inside --out " \
           f"{rec / 'results.parquet'} (batch's result files, not recordings) left out" in err
    code, out, err = _run([*args[:1], rec / "results.parquet" / "*.parquet", *args[2:]])
    assert code == 2 and "no recording matches" in err and "1 file(s) inside --out" in err


def test_an_actuator_of_two_rigs_is_not_stored_and_named(case, tmp_path):
    """Finding 3 through the command: rigM holds a VCA and an EHA recording. The other
    actuator is stored, rigM not at all, the message names both files, exit code 2."""
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    rng = np.random.default_rng(1)
    paths = {}
    for folder, name, rig in (("rigM", "a_vca", "vca"), ("rigM", "b_eha", "eha"),
                              ("rigN", "c_vca", "vca")):
        (tmp_path / "rec" / folder).mkdir(parents=True, exist_ok=True)
        p = tmp_path / "rec" / folder / f"{name}.parquet"
        write_recording(Recording({"p1": 1e7 + 1e5 * rng.normal(size=3000)}, 1000.0,
                                  meta={"system": rig}), p)
        paths[name] = p
    db = tmp_path / "ev.db"
    code, out, err = _run(["batch", tmp_path / "rec" / "**" / "*.parquet", "--config", job,
                           "-o", tmp_path / "res", "--scheduler", "serial", "--no-progress",
                           "--store", db])
    assert code == 2
    assert "1 run(s) written to" in out
    assert err == (f"  not stored: actuator 'rigM': its recordings disagree on the rig "
                   f"({paths['a_vca']} says vca, {paths['b_eha']} says eha): give them "
                   "different actuator names\n")
    st = EventStore(db)
    assert st.actuator_names() == ["rigN"] and st.count("runs") == 1
    st.close()
    con = sqlite3.connect(db)
    assert con.execute("select status from runs").fetchall() == [("finished",)]
    con.close()
