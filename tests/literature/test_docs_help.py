"""Docstrings and help that state what the code does (audit: the EKF detector's docstring
missed its "coefficient" feature and pressure_noise_std_pa=None; ekf_feature's summary missed
"coefficient"; `leakdiag fit --help` said every file was for detect, monitor and batch)."""

import pytest
from click.testing import CliRunner

from leakdiag.bench.registry import METHODS, make_detector
from leakdiag.detect.base import Alarm
from leakdiag.literature.detectors import EKFDetector
from leakdiag.literature.ekf import EKF_FEATURES, ekf_feature


def test_ekf_docstrings_name_every_feature_and_the_matched_noise():
    doc = EKFDetector.__doc__
    assert 'feature : {"leak_flow", "residual", "coefficient"}' in doc
    assert "pressure_noise_std_pa : float or None" in doc and "matched at :meth:`fit`" in doc
    summary = ekf_feature.__doc__.split("\n\n")[0]
    assert "coefficient" in summary
    assert set(EKF_FEATURES) == {"leak_flow", "residual", "coefficient"}


def _streamable(method):
    d = make_detector(method, "vca", Alarm())
    return callable(getattr(d, "score_windows", None)) or callable(getattr(d, "spec", None))


def test_fit_help_says_which_files_monitor_and_batch_take():
    from leakdiag.cli.main import cli

    rendered = " ".join(CliRunner().invoke(cli, ["fit", "--help"]).output.split())
    assert "for detect, monitor and batch" not in rendered
    assert "save it for detect (and monitor, batch)" in rendered
    from leakdiag.cli.fit import fit

    text = " ".join(fit.help.split())  # unwrapped (click wraps at hyphens)
    assert ("monitor runs window by window with the single-feature "
            "detectors (acf-p1, acf-p2, ccf-p1p2, ccf-ux, mlr-p1); combined, wavelet-p1, "
            "wavelet-p1p2, fft-p1, emd-p1, ekf and flow-balance judge whole recordings: batch "
            "reads each file whole for them, and monitor judges a stream with them in "
            "consecutive segments (--segment)") in text
    # the lists are the registry's streamable and whole-recording detectors (monitor's and
    # batch's check: a spec() or score_windows(), cli/monitor.py check_streamable)
    assert sorted(m for m in METHODS if _streamable(m)) == sorted(
        ["acf-p1", "acf-p2", "ccf-p1p2", "ccf-ux", "mlr-p1"])
    assert sorted(m for m in METHODS if not _streamable(m)) == sorted(
        ["combined", "wavelet-p1", "wavelet-p1p2", "fft-p1", "emd-p1", "ekf", "flow-balance"])


def test_detect_md_states_the_eha_input_hook_that_exists():
    from pathlib import Path

    import numpy as np

    from leakdiag.sim.excitation import structured_excitation
    from leakdiag.sim.eha.simulate import simulate_eha

    text = " ".join((Path(__file__).parents[2] / "docs" / "detect.md").read_text().split())
    assert "has no input hook" not in text  # it said so while simulate_eha had one
    assert 'simulate_eha(..., input_signal=structured_excitation("eha"))' in text
    # the hook as described: the motor command is the +-3 V steps, -3 V for the first
    # quarter period, +3 V from 0.25 to 0.75 s, then alternating every half period
    rec = simulate_eha(duration=2.0, leak_lpm=None, seed=1,
                       input_signal=structured_excitation("eha"))
    u, t = rec["u"], rec.time
    q = 1e-3  # the recorded command is the DAC's rounding of +-3 V (3.00049 V)
    for lo, hi, level in ((0.0, 0.24, -3.0), (0.26, 0.74, 3.0), (0.76, 1.24, -3.0),
                          (1.26, 1.74, 3.0)):
        seg = u[(t > lo) & (t < hi)]
        assert np.all(np.abs(seg - level) <= q), (lo, hi)


def test_literature_md_ekf_section_is_the_filter_in_the_code():
    from pathlib import Path

    import numpy as np

    from leakdiag.literature._ekf_kernel import N_STATE
    from leakdiag.literature.ekf import EKFParams, run_vca_ekf
    from leakdiag.sim.vca.simulate import simulate_vca

    text = " ".join((Path(__file__).parents[2] / "docs" / "literature.md").read_text().split())
    ekf_part = text[text.index("### EKF"):text.index("## Structured excitation")]
    assert N_STATE == 8 and "**State** (8): `[x, v, P1, P2, x_v, v_v, k_l, f_d]`" in ekf_part
    assert "enforced by projection" not in ekf_part and "7x7" not in ekf_part
    assert "knows the simulator's exact model" not in text
    # the honesty caveat's load case, as the section states it: the spring load with a
    # no-load filter reads the coefficient and the leak right (the 7-state filter: 2.4 x)
    assert "1.045e-8 against the true 1.044e-8, the leak read 0.500 L/min" in ekf_part
    rec = simulate_vca(duration=60, leak_lpm=0.5, onset=30, seed=3, load="spring")
    res = run_vca_ekf(rec, EKFParams(load="none"))
    late = res.time >= 40
    assert np.mean(res.leak_coefficient[late]) == pytest.approx(1.045e-8, rel=1e-3)
    assert rec.meta["leak_coefficient"] == pytest.approx(1.044e-8, rel=1e-3)
    from leakdiag.literature.detectors import EKFDetector

    assert EKFDetector(load="none").leak_size_lpm(rec, 30.0) == pytest.approx(0.500, abs=0.0005)
