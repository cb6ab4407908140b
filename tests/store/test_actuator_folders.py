"""One actuator name, two folders: the store keeps their runs apart across commands and jobs.

A store audit (2026-11-29): a second ``batch`` job stored the healthy ``siteB/rig1`` under the
name of the first job's leaking ``siteA/rig1`` and the fleet page showed it OK (within one job
:func:`leakdiag.store.writers.actuator_names` refuses such a pair; across jobs nothing did);
``monitor --segment`` stored the path as typed, relative, which the check that keeps one stem
of two folders apart does not compare, so a later ``detect`` of another folder's ``run1``
joined it; a name longer than the store's column crashed on PostgreSQL after the verdict.
"""

from pathlib import Path

import pytest

from leakdiag.io import write_recording
from leakdiag.sim import simulate_vca
from leakdiag.store import EventStore


@pytest.fixture(scope="module")
def sites(tmp_path_factory):
    from leakdiag.cli.main import main

    d = tmp_path_factory.mktemp("sites")
    healthy = [str(write_recording(simulate_vca(duration=30.0, leak_lpm=None, seed=s),
                                   d / f"h{s}.parquet")) for s in (1, 2, 3)]
    det = d / "acf.joblib"
    assert main(["fit", *(a for h in healthy for a in ("--healthy", h)), "-m", "acf-p1",
                 "--false-alarm-rate", "100", "-o", str(det), "--no-progress"]) == 0
    for site, seed in (("siteA", 21), ("siteB", 22)):
        (d / site / "rig1").mkdir(parents=True)
        write_recording(simulate_vca(duration=30.0, leak_lpm=None, seed=seed),
                        d / site / "rig1" / "run1.parquet")
    return d, det


def test_a_second_batch_job_does_not_merge_another_folder_into_an_actuator(sites, run_cli):
    d, det = sites
    db = d / "jobs.db"
    for site, code_wanted in (("siteA", 0), ("siteB", 2)):
        code, out, err = run_cli(["batch", str(d / site / "**" / "*.parquet"), "--detector",
                                  str(det), "-o", str(d / f"res{site}.parquet"), "--scheduler",
                                  "serial", "--store", str(db), "--no-progress"])
        assert code == code_wanted, (out, err)
    assert "not stored: actuator 'rig1' already holds runs of" in err
    assert "siteA/rig1/run1.parquet, a file in another folder than" in err
    st = EventStore(db, create=False)
    sources = set(st.runs_of("rig1")["source"])
    st.close()
    assert sources == {str((d / "siteA" / "rig1" / "run1.parquet").resolve())}
    # one file per actuator (--actuator-from stem): siteB's run1 is not siteA's run1 either
    db2 = d / "stems.db"
    for site, code_wanted in (("siteA", 0), ("siteB", 2)):
        code, out, err = run_cli(["batch", str(d / site / "**" / "*.parquet"), "--detector",
                                  str(det), "-o", str(d / f"stem{site}.parquet"), "--scheduler",
                                  "serial", "--store", str(db2), "--actuator-from", "stem",
                                  "--no-progress"])
        assert code == code_wanted, (out, err)
    assert "not stored: actuator 'run1' already holds runs of" in err
    # the same folder again (a new job over it) is the same actuator
    code, out, err = run_cli(["batch", str(d / "siteA" / "**" / "*.parquet"), "--detector",
                              str(det), "-o", str(d / "resA2.parquet"), "--scheduler",
                              "serial", "--store", str(db), "--no-progress"])
    assert code == 0, err


def test_monitor_segments_store_the_real_path(sites, run_cli, monkeypatch):
    d, det = sites
    fb = d / "fb.joblib"
    healthy = [str(d / f"h{s}.parquet") for s in (1, 2, 3)]
    code, _, err = run_cli(["fit", *(a for h in healthy for a in ("--healthy", h)), "-m",
                            "flow-balance", "-o", str(fb), "--no-progress"])
    assert code == 0, err
    db = d / "seg.db"
    monkeypatch.chdir(d)
    code, _, err = run_cli(["monitor", "siteA/rig1/run1.parquet", "--detector", str(fb),
                            "--segment", "15", "--store", str(db), "-q"])
    assert code == 0, err
    st = EventStore(db, create=False)
    sources = list(st.runs_of("run1")["source"])
    st.close()
    here = str((d / "siteA" / "rig1" / "run1.parquet").resolve())
    assert sources and all(s.startswith(here + " [") for s in sources), sources
    # so detect of another folder's run1 is refused, as after a detect
    code, _, err = run_cli(["detect", "siteB/rig1/run1.parquet", "--detector", str(det),
                            "--store", str(db)])
    assert code == 2 and "already holds runs of" in err and "another folder" in err, err


def test_a_name_longer_than_the_store_holds_is_refused_before_the_work(sites, run_cli):
    d, det = sites
    code, out, err = run_cli(["detect", str(d / "siteA" / "rig1" / "run1.parquet"),
                              "--detector", str(det), "--store", str(d / "long.db"),
                              "--actuator", "L" * 250])
    assert code == 2 and "250 characters, at most 200 are stored" in err, (out, err)
    assert "Decision" not in out and "Traceback" not in err
