"""``leakdiag demo`` runs thesis case study 1 as the reproduction runs it (thesis audit
2026-11-28, F8: it said "case study 1" but used the simulator's 2-20 mm steps and default
sensors)."""

import dataclasses

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.studies.protocol import THESIS, build_cases, case_simulator_kwargs, simulate_case
from leakdiag.sim.sensors import THESIS_EHA_SENSORS, THESIS_VCA_SENSORS


def test_case_study_1_arguments_are_the_protocols():
    vca, eha = case_simulator_kwargs("vca", 1), case_simulator_kwargs("eha", 1)
    # Sec. 5.1 case study 1: 0.10 L/min from 200 s of 400 s, no load, steps 8-20 mm
    assert (vca["duration"], vca["onset"], vca["leak_lpm"], vca["load"]) == \
        (400.0, 200.0, 0.1, "none")
    assert (vca["reference"].min_amplitude_m, vca["reference"].max_amplitude_m) == (0.008, 0.02)
    assert vca["sensor_params"] is THESIS_VCA_SENSORS
    # Sec. 6 case study 1: 1.2 L/min from 90 s of 180 s, no load
    assert (eha["duration"], eha["onset"], eha["leak_lpm"], eha["load"]) == \
        (180.0, 90.0, 1.2, "none")
    assert eha["sensor_params"] is THESIS_EHA_SENSORS and "reference" not in eha
    assert case_simulator_kwargs("vca", 2)["reference"].min_amplitude_m == 0.005  # 5-17 mm
    with pytest.raises(ValueError, match="case_study=3 must be 1 or 2"):
        case_simulator_kwargs("vca", 3)
    with pytest.raises(ValueError, match="unknown system 'x'"):
        case_simulator_kwargs("x", 1)


@pytest.mark.filterwarnings("ignore:.*have zero variance")  # u,x windows while the piston rests
def test_demo_is_the_reproductions_case_study_1(run_cli, tmp_path):
    code, out, err = run_cli(["demo", "--seed", "0", "-o", str(tmp_path / "demo")])
    assert code == 0, err
    lines = out.rstrip().splitlines()
    assert lines[0] == ("Simulating the VCA (thesis case study 1, Sec. 5.1: 0.1 L/min leak from "
                        "200 s of 400 s, load 'none', reference steps 8-20 mm, the rig's sensor "
                        "chain; seed 0)...")
    assert lines[-1].startswith("Decision: ")  # `make demo` ends with the decision
    # the very recording `leakdiag reproduce` measures for Tables 5-1 to 5-11 (seed 0)
    case = next(c for c in build_cases(dataclasses.replace(THESIS, cache_dir=str(tmp_path / "c")),
                                       ("vca",))
                if c["kind"] == "tables" and c["case_study"] == 1)
    ours = ld.io.read_recording(tmp_path / "demo" / "run.parquet")
    ref = simulate_case(case)
    for ch in ("p1", "p2", "x", "u"):
        np.testing.assert_array_equal(np.asarray(ours[ch]), np.asarray(ref[ch]), err_msg=ch)
