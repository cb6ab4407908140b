"""`leakdiag sensitivity` on one short VCA experiment: every VCA method measured, ranges printed."""

import pandas as pd
import pytest

import leakdiag.sim as sim
from leakdiag.cli.main import main
from leakdiag.studies.protocol import SENSITIVITY_METHODS


@pytest.mark.skipif(not hasattr(sim, "simulate_vca"), reason="no VCA simulator")
def test_sensitivity_cli_one_experiment(tmp_path, capsys):
    out = tmp_path / "s"
    code = main(["sensitivity", "vca", "--quick", "--leaks", "0.3", "--seeds", "3",
                 "--durations", "24", "--loads", "none", "--scheduler", "serial",
                 "--cache-dir", str(tmp_path / "cache"), "--out", str(out)])
    assert code == 0
    rows = pd.read_csv(out / "sensitivity.csv")
    assert len(rows) == len(SENSITIVITY_METHODS["vca"])
    assert set(rows.leak_lpm) == {0.3} and set(rows.duration) == {24.0}
    assert set(rows.load) == {"none"} and set(rows.seed) == {3}
    summ = pd.read_csv(out / "sensitivity_summary.csv")
    assert (summ.n_runs <= 1).all()
    assert (summ.min_pct.dropna() == summ.max_pct.dropna()).all()  # one run: min == max
    assert (out / "sensitivity_vca.png").stat().st_size > 1000
    assert "thesis_min_pct" in capsys.readouterr().out
