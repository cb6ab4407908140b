"""``leakdiag detect FILE --healthy ...`` on simulated VCA recordings written to Parquet."""

import pytest

from leakdiag.cli.detect import verdict_table
from leakdiag.cli.main import main


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    d = tmp_path_factory.mktemp("detect")
    healthy = []
    for s in range(3):
        rec = simulate_vca(duration=30.0, leak_lpm=None, seed=20 + s, reference_seed=120 + s)
        healthy.append(str(write_recording(rec, d / f"healthy{s}.parquet")))
    leak = simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=30, reference_seed=130)
    return healthy, str(write_recording(leak, d / "leak.parquet"))


def test_verdict_table_flags_leak_after_onset(files):
    healthy, leak = files
    # 3 healthy runs of 25 s monitored support false-alarm probabilities down to 1/4 per run
    # (conformal threshold = the largest healthy CUSUM maximum, k = 1): 40 per hour = 0.28 per run
    tab = verdict_table(leak, healthy, methods=["ccf-p1p2"], false_alarms_per_hour=40.0)
    row = tab.iloc[0]
    assert bool(row.leak) and row.alarm_time_s >= 15.0 and abs(row.onset_s - 15.0) < 3.0
    assert row.n_healthy == 3


def test_cli_prints_verdict_and_rejects_unknown_method(files, capsys):
    healthy, leak = files
    args = ["detect", leak, "--methods", "ccf-p1p2", *RATE_RUN]
    for h in healthy:
        args += ["--healthy", h]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "ccf-p1p2" in out and "True" in out
    assert "Decision: LEAK -- alarm from ccf-p1p2" in out
    # a feature's alarm is a change of the feature, which other changes cause too (audit
    # 2026-11-27, finding 3): said under the decision
    assert ("\n  cause (ccf-p1p2): its alarm is a change of its statistic since the healthy "
            "recordings, which a leak or another change (load, reference, temperature, a sensor) "
            "can cause as well;") in out
    assert main(args[:2] + ["--methods", "nope"] + args[4:]) == 2
    assert "unknown method 'nope'" in capsys.readouterr().err


# ------------------------------------------------------------------ issue 15
#: Rates that 3 healthy 30-s runs can support even with a distribution-free (conformal) threshold,
#: whose best promise with n healthy runs is 1/(n + 1) per run (docs/detect.md): per hour for fit,
#: per run for detect --healthy.
RATE_H = ["--false-alarm-rate", "40"]
RATE_RUN = ["--false-alarm-rate", "0.5"]


def _h(healthy):
    return [a for h in healthy for a in ("--healthy", h)]


def test_fit_then_detect_with_the_detector_file(files, tmp_path, capsys):
    healthy, leak = files
    det = tmp_path / "det.joblib"
    assert main(["fit", *_h(healthy), "--method", "ccf-p1p2", *RATE_H, "-o", str(det)]) == 0
    out = capsys.readouterr().out
    assert "ccf-p1p2 for the VCA at 1000 Hz, channels p1,p2" in out
    assert main(["detect", leak, "--detector", str(det)]) == 0
    out = capsys.readouterr().out
    assert "Decision: LEAK" in out
    # the saved detector gives the same verdict as fitting at the same rate in the same run
    from leakdiag.cli.fit import fit_detector
    from leakdiag.io import read_recording
    from leakdiag.stream.detector_file import load_detector_file

    loaded, meta = load_detector_file(det)
    fresh = fit_detector("ccf-p1p2", "vca", [read_recording(h) for h in healthy],
                         false_alarms_per_hour=40.0)
    rec = read_recording(leak)
    assert loaded.predict(rec).score_max == fresh.predict(rec).score_max
    assert (meta.system, meta.sample_rate_hz, meta.channels, meta.units) == (
        "vca", 1000.0, ("p1", "p2"), {"p1": "Pa", "p2": "Pa"})


def test_detect_refuses_file_at_another_sample_rate_than_the_detector(files, tmp_path, capsys):
    healthy, leak = files
    import pandas as pd

    det = tmp_path / "det.joblib"
    assert main(["fit", *_h(healthy), "--method", "acf-p1", *RATE_H, "-o", str(det)]) == 0
    df = pd.read_parquet(leak)
    df["time"] = df["time"] * 2.0
    slow = tmp_path / "slow.csv"
    df.to_csv(slow, index=False)
    capsys.readouterr()
    assert main(["detect", str(slow), "--detector", str(det)]) == 2
    assert "slow.csv: sample rate 500 Hz, but" in capsys.readouterr().err
    # and against healthy files at 1000 Hz
    assert main(["detect", str(slow), *_h(healthy)]) == 2
    assert "sample rate 1000 Hz differs from" in capsys.readouterr().err


def test_detect_refuses_healthy_files_of_another_system(files, tmp_path, capsys):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_eha

    healthy, leak = files
    eha = simulate_eha(duration=2.0, leak_lpm=None, seed=1)
    p = str(write_recording(eha.resample(1000.0) if eha.sample_rate != 1000.0 else eha,
                            tmp_path / "eha.parquet"))
    assert main(["detect", leak, "--healthy", p]) == 2
    assert "system 'eha' differs from" in capsys.readouterr().err


def test_detect_time_in_milliseconds_warns_and_time_unit_fixes_it(files, tmp_path, capsys):
    import pandas as pd

    healthy, leak = files
    df = pd.read_parquet(leak)
    df["time"] = df["time"] * 1000.0
    ms = tmp_path / "ms.csv"
    df.to_csv(ms, index=False)
    with pytest.warns(UserWarning, match="ms.csv: sample rate 1 Hz .* --time-unit ms"):
        assert main(["detect", str(ms), *_h(healthy), "--methods", "acf-p1"]) == 2
    assert "sample rate 1000 Hz differs from" in capsys.readouterr().err
    hms = []
    for i, h in enumerate(healthy):  # --time-unit applies to every file: healthy ones in ms too
        d = pd.read_parquet(h)
        d["time"] = d["time"] * 1000.0
        hms.append(str(tmp_path / f"h{i}.csv"))
        d.to_csv(hms[-1], index=False)
    assert main(["detect", str(ms), *_h(hms), "--methods", "acf-p1", *RATE_RUN,
                 "--time-unit", "ms", "--system", "vca"]) == 0
    assert "Decision: LEAK" in capsys.readouterr().out


def test_detect_needs_a_system_when_no_file_says(files, tmp_path, capsys):
    import pandas as pd

    healthy, leak = files
    paths = []
    for i, f in enumerate([leak, *healthy[:2]]):
        p = tmp_path / f"plain{i}.csv"
        pd.read_parquet(f).to_csv(p, index=False)  # CSV: no metadata, no system
        paths.append(str(p))
    assert main(["detect", paths[0], *_h(paths[1:]), "--methods", "acf-p1"]) == 2
    assert "give --system vca or --system eha" in capsys.readouterr().err


def test_detect_refuses_a_healthy_file_that_says_it_leaks(files, capsys):
    healthy, leak = files
    assert main(["detect", healthy[0], "--healthy", leak, "--healthy", healthy[1],
                 "--methods", "acf-p1"]) == 2
    err = capsys.readouterr().err
    assert err.strip().endswith(f"--healthy: healthy recording 1 ({leak}) leaks by its metadata "
                                "(leak_lpm=0.5 L/min from 15 s): fit on healthy recordings only")


def test_analyze_refuses_the_same_healthy_file_twice(files, capsys):
    """A review (2026-11-27): the same --healthy file twice pooled its chunk RMS values twice
    in analyze's reference, doubling n_reference behind its p-values."""
    healthy, leak = files
    assert main(["analyze", leak, "--healthy", healthy[0], "--healthy", healthy[0]]) == 2
    assert capsys.readouterr().err.strip().endswith(
        f"--healthy: healthy recording 2 ({healthy[0]}) holds the same samples as healthy "
        f"recording 1 ({healthy[0]}): a recording given twice would count as two independent "
        "healthy runs")


def test_a_method_that_cannot_judge_the_file_gets_an_error_row(files):
    """Found by an API audit (2026-11-27): a detector's refusal in predict (too short, units)
    stopped the whole table; now that method's row says why and the others judge."""
    from leakdiag.cli.detect import _row, overall_verdict
    from leakdiag.io import RecordingError

    from types import SimpleNamespace

    from leakdiag.detect.base import Alarm

    class Refuses:
        alarm_threshold_ = threshold_basis_ = None

        def _alarm(self):
            return Alarm()

        def predict(self, rec):
            raise RecordingError("predict: x.parquet: too short to judge")

    rec = SimpleNamespace(duration=30.0, n_samples=30000, sample_rate=1000.0, meta={})
    assert _row("flow-balance", Refuses(), rec, 3) == {
        "method": "flow-balance", "error": "predict: x.parquet: too short to judge"}
    import pandas as pd

    tab = pd.DataFrame([{"method": "flow-balance", "error": "too short"},
                        {"method": "acf-p1", "error": "constant"}])
    assert overall_verdict(tab, 30.0) == (
        "inconclusive", "no method could judge the file (flow-balance, acf-p1)")


def test_detect_without_references_is_a_usage_error(files, capsys):
    _, leak = files
    assert main(["detect", leak]) == 2
    assert "give --healthy FILE (repeatable) or --detector FILE" in capsys.readouterr().err


def test_fit_with_calibration_gives_the_leak_size_with_interval(files, tmp_path, capsys):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    import dataclasses

    import numpy as np

    healthy, leak = files
    # the thesis features do not follow these simulated leaks (shifts 1.42, 1.40, 1.05 std at
    # 0.1, 0.3, 0.8 L/min): such a calibration is refused (it used to size any leak as noise)
    cal = []
    for i, q in enumerate((0.1, 0.3, 0.8)):
        rec = simulate_vca(duration=30.0, leak_lpm=q, onset=15.0, seed=60 + i, reference_seed=160 + i)
        cal += ["--calibrate", str(write_recording(rec, tmp_path / f"cal{i}.parquet"))]
    det = tmp_path / "det.joblib"
    assert main(["fit", *_h(healthy), "-m", "ccf-p1p2", *RATE_H, *cal, "-o", str(det)]) == 2
    assert "the feature's shift does not follow the leak flow on these 3 runs" in \
        capsys.readouterr().err

    # a feature that does follow a "leak": noise in p2 after the onset, in proportion to it,
    # lowers the cross-correlation of p1 and p2 (recordings made for the test, not physics)
    def noisy(q, seed, path):
        rec = simulate_vca(duration=30.0, leak_lpm=None, seed=seed, reference_seed=100 + seed)
        p2 = rec["p2"].copy()
        after = rec.time >= 15.0
        p2[after] += np.random.default_rng(seed).normal(0.0, 3e4 * q, after.sum())
        meta = {**rec.meta, "onset": 15.0, "leak_lpm": q, "leak_lpm_achieved": q}
        return str(write_recording(dataclasses.replace(
            rec, channels={**rec.channels, "p2": p2}, meta=meta), path))

    # (a healthy run's seed: the same operation before the onset, one noise pattern scaled)
    # (the calibration reads each run's shift as predict does, on the runs it alarms on: the
    # 0.2 "leak" does not alarm and is left out, and three runs do not pass the slope test)
    cal = [a for i, q in enumerate((0.2, 0.5, 1.0, 1.5))
           for a in ("--calibrate", noisy(q, 20, tmp_path / f"n{i}.parquet"))]
    assert main(["fit", *_h(healthy), "-m", "ccf-p1p2", *RATE_H, *cal, "-o", str(det)]) == 2
    assert "(the detector alarms on 3 of the 4 calibration recordings; the others are left " \
        "out)" in capsys.readouterr().err
    cal += [a for i, q in enumerate((0.8, 1.2, 2.0))
            for a in ("--calibrate", noisy(q, 20, tmp_path / f"m{i}.parquet"))]
    leak = noisy(0.8, 21, tmp_path / "nleak.parquet")
    assert main(["fit", *_h(healthy), "-m", "ccf-p1p2", *RATE_H, *cal, "-o", str(det)]) == 0
    assert "leak size calibrated on 7 recording(s)" in capsys.readouterr().out
    assert main(["detect", leak, "--detector", str(det)]) == 0
    out = capsys.readouterr().out
    line = [ln for ln in out.splitlines() if "leak size (ccf-p1p2)" in ln][0]
    est = float(line.split(": ")[1].split(" L/min")[0])
    lo, hi = (float(v) for v in line.split("interval ")[1].split(" L/min")[0].split("-"))
    assert lo <= est <= hi and est > 0  # the point estimate lies in its interval
    # without calibration detect says the size is not estimated
    assert main(["fit", *_h(healthy), "-m", "ccf-p1p2", *RATE_H, "-o", str(det)]) == 0
    assert main(["detect", leak, "--detector", str(det)]) == 0
    assert "leak size: not estimated" in capsys.readouterr().out
    assert main(["fit", *_h(healthy), "-m", "ccf-p1p2", *RATE_H, *cal[:2], "-o", str(det)]) == 2
    assert "at least 3 recordings with known leaks" in capsys.readouterr().err
    assert main(["fit", *_h(healthy), "-m", "ccf-p1p2", *RATE_H, *cal[:6], "--calibrate",
                 healthy[0], "-o", str(det)]) == 2
    assert "healthy0.parquet: its metadata does not give the leak onset" in capsys.readouterr().err


@pytest.mark.parametrize("method", ["combined", "wavelet-p1", "fft-p1", "mlr-p1"])
def test_fit_saves_any_registry_detector_and_detect_reads_it(files, tmp_path, capsys, method):
    from leakdiag.cli.fit import fit_detector
    from leakdiag.io import read_recording
    from leakdiag.stream.detector_file import load_detector_file

    healthy, leak = files
    det = tmp_path / f"{method}.joblib"
    assert main(["fit", *_h(healthy), "-m", method, *RATE_H, "-o", str(det)]) == 0
    loaded, meta = load_detector_file(det)
    assert meta.method == method and meta.n_healthy == 3
    fresh = fit_detector(method, "vca", [read_recording(h) for h in healthy],
                         false_alarms_per_hour=40.0)
    rec = read_recording(leak)
    assert loaded.predict(rec).score_max == pytest.approx(fresh.predict(rec).score_max, rel=1e-12)
    capsys.readouterr()
    assert main(["detect", leak, "--detector", str(det), "--no-progress"]) == 0
    assert "Decision: " in capsys.readouterr().out


def test_detect_prints_the_conformal_p_value_by_its_name(files, capsys):
    """Issue 15: 'confidence' 0.75 on a no-leak row read as the opposite of what it is."""
    healthy, leak = files
    args = ["detect", leak, "--methods", "ccf-p1p2", *RATE_RUN, *_h(healthy)]
    assert main(args) == 0
    header = capsys.readouterr().out.splitlines()[0].split()
    assert "p_value" in header and "confidence" not in header


def test_detect_eha_flow_balance_states_the_profiled_transducer_offset(tmp_path, capsys):
    # unit 17's chamber transducers differ by -32.7 kPa at zero; without load the EHA's size
    # profiles that offset out (docs/detect.md 8.5) and the command says so beside the size
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_eha

    healthy = [str(write_recording(simulate_eha(duration=60.0, leak_lpm=None, machine=17,
                                                seed=s), tmp_path / f"h{s}.parquet"))
               for s in range(4)]
    rec = simulate_eha(duration=60.0, leak_lpm=0.1, onset=30.0, machine=17, seed=99)
    leak = str(write_recording(rec, tmp_path / "leak.parquet"))
    det = tmp_path / "eha.joblib"
    assert main(["fit", *_h(healthy), "--method", "flow-balance", "--system", "eha",
                 "-o", str(det)]) == 0
    capsys.readouterr()
    assert main(["detect", leak, "--detector", str(det)]) == 0
    out = capsys.readouterr().out
    assert "Decision: LEAK" in out
    line = next(x for x in out.splitlines() if "leak size (flow-balance)" in x)
    size = float(line.split(": ")[1].split()[0])
    assert abs(size / rec.meta["leak_lpm_achieved"] - 1) <= 0.03
    assert ("interval: the coefficient's statistical error and an effective P1-P2 offset (the "
            "transducers' zero error and whatever else shifts P1 - P2 at the working pressure) "
            "found on the leak's windows, -3") in line  # -32 kPa


def test_a_decision_names_the_methods_that_did_not_alarm():
    # decision audit 2026-11-27: LEAK from ccf-p1p2 on a healthy file while the flow balance
    # read p = 0.373, with no word of the disagreement
    import pandas as pd

    from leakdiag.cli.detect import overall_verdict

    row = {"false_alarms_per_run": 0.01, "false_alarms_per_run_guaranteed": True}
    tab = pd.DataFrame([{"method": "flow-balance", "leak": False, "confidence": 0.373, **row},
                        {"method": "ccf-p1p2", "leak": True, "confidence": 0.111, **row},
                        {"method": "acf-p1", "leak": False, "confidence": 0.9, **row}])
    assert overall_verdict(tab, 120.0) == (
        "leak", "alarm from ccf-p1p2, none from flow-balance (p = 0.373), acf-p1 (p = 0.9): the "
                "methods disagree, and the decision is any method's alarm; false-alarm rate for "
                "this run at most 0.03 (sum over 3 method(s))")
    agree = tab.assign(leak=True)
    assert overall_verdict(agree, 120.0)[1].startswith(
        "alarm from flow-balance, ccf-p1p2, acf-p1; false-alarm")


def test_detect_fits_the_flow_balance_by_default_and_states_its_sensitivity(files, tmp_path,
                                                                             capsys):
    """Without --methods: the flow balance (its channels are in the files); its NO LEAK says
    how large a leak it would have seen, or why it does not (decisions audit 2026-11-27,
    finding 4: the former default features read NO LEAK on 0.2-0.5 L/min leaks)."""
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    healthy, _ = files
    ok = write_recording(simulate_vca(duration=30.0, leak_lpm=None, seed=41, reference_seed=141),
                         tmp_path / "ok.parquet")
    assert main(["detect", str(ok), *_h(healthy), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1].split()[0] == "flow-balance" and "ccf-p1p2" not in out
    assert "Decision: NO LEAK -- no method alarmed" in out
    # the fixture runs have no load: 3x the error model's size (its own alarmed in 21 of 38)
    line = [ln for ln in out.splitlines() if ln.startswith("  sensitivity (flow-balance): ")]
    assert len(line) == 1 and "L/min or more from " in line[0]
    assert "3 times its error model's size (on the VCA without load" in line[0]


def test_default_methods_fall_back_to_the_features_when_a_channel_is_missing(files):
    from leakdiag.cli.detect import default_methods, sensitivity_lines
    from leakdiag.io import read_recording

    healthy, leak = files
    rec, train = read_recording(leak), [read_recording(h) for h in healthy]
    assert default_methods(rec, train, "vca", leak, healthy) == (["flow-balance"], None)
    no_u = rec.__class__({k: v for k, v in rec.channels.items() if k != "u"}, rec.sample_rate,
                         rec.start_time, {k: v for k, v in rec.units.items() if k != "u"},
                         dict(rec.meta))
    methods, why = default_methods(rec, [train[0], no_u], "vca", leak, ["h0", "h1.csv"])
    assert methods == ["acf-p1", "ccf-p1p2", "mlr-p1"]
    assert why.startswith("h1.csv has no channel(s) ['u'], which the flow balance reads: "
                          "judged with acf-p1, ccf-p1p2, mlr-p1 instead")
    import pandas as pd

    lines = sensitivity_lines(pd.DataFrame({"method": methods, "leak": [False, None, False]}))
    assert lines == ["sensitivity (acf-p1, mlr-p1): not stated: feature detectors cannot say "
                     "how large a leak they would miss; the flow balance (--methods "
                     "flow-balance, or leakdiag fit --method flow-balance) states it "
                     "(docs/detect.md section 6)"]


def test_an_alarm_expected_by_chance_in_a_long_run_is_no_evidence():
    """A flow-balance audit (2026-11-28, finding 4): a detector fitted for 20 false alarms per
    hour judged 30-min runs: about 9 false alarms expected, p = 1, yet LEAK with an onset and a
    size promised at 0.97 (a healthy run; a 0.1 L/min leak sized 0.0056 from an earlier false
    alarm). Such an alarm is INCONCLUSIVE; another method's evidence still decides."""
    import pandas as pd

    from leakdiag.cli.detect import overall_verdict

    row = {"false_alarms_per_run": 1.0, "false_alarms_per_run_guaranteed": False,
           "threshold_method": "conformal"}
    tab = pd.DataFrame([{"method": "flow-balance", "leak": True, "confidence": 1.0,
                         "false_alarms_expected": 9.14, **row}])
    dec, why = overall_verdict(tab, 1800.0)
    assert dec == "inconclusive" and why.startswith(
        "alarm from flow-balance, but about 9.14 false alarms are expected by chance in a run "
        "this long at its false-alarm rate: the alarm is no evidence of a leak;")
    both = pd.concat([tab, pd.DataFrame([{"method": "acf-p1", "leak": True, "confidence": 0.01,
                                          "false_alarms_expected": 0.2, **row}])],
                     ignore_index=True)
    dec, why = overall_verdict(both, 1800.0)
    assert dec == "leak" and why.startswith("alarm from acf-p1; ")
    assert "; alarm from flow-balance, but about 9.14 false alarms are expected" in why
