"""VCA simulator speed (issue goal: a 400 s experiment at 1 kHz in under 1 s after JIT warm-up).

The fast path is ``simulate_vca`` with a fixed leak coefficient (one run, sensors on, the
compiled RK4 kernel). The reference is the same closed loop integrated by SciPy's implicit
``solve_ivp`` (Radau, rtol 1e-8), run on a shorter experiment because it is ~1000x slower;
its time is scaled linearly to 400 s and the table says so. Timings are CPU time (best of
repeats); the wall time of the fast path is printed as well. Nothing here fails on a slow
machine.
"""

import time

import numpy as np

from leakdiag.sim import (
    FixedGainController,
    LeakSchedule,
    OperatingConditions,
    PseudoRandomSteps,
    VCAParams,
    simulate_vca,
)
from leakdiag.sim.vca.scipy_reference import integrate_closed_loop_scipy

DURATION_S = 400.0
REFERENCE_S = 2.0
GOAL_S = 1.0
K_LEAK = 1.6e-8  # turbulent, about 0.1 L/min without load (calibrated value, docs/models.md)


def test_bench_vca_400s_vs_scipy(benchmark, record_ratio, best_time):
    def fast():
        return simulate_vca(duration=DURATION_S, onset=200.0, leak_lpm=0.1,
                            leak_coefficient=K_LEAK, seed=1)

    rec = benchmark.pedantic(fast, rounds=3, iterations=1, warmup_rounds=1)
    fast_cpu = best_time(fast, repeats=3, warmup=0)
    fast_wall = best_time(fast, repeats=2, warmup=0, timer=time.perf_counter)
    assert rec.n_samples == int(DURATION_S * 1000)

    n = int(REFERENCE_S * 1000)
    xr = PseudoRandomSteps().samples(np.arange(n) / 1000.0, np.random.default_rng(1))
    args = (VCAParams().to_array("turbulent", "none"), FixedGainController().to_array(), 10.0,
            K_LEAK, LeakSchedule("step", onset_s=1.0).to_array(),
            OperatingConditions().to_array(REFERENCE_S), [0.0, 0.0, 8.6e6, 8.6e6, 0.0, 0.0])
    ref_cpu = best_time(lambda: integrate_closed_loop_scipy(xr, 1000.0, *args), repeats=1,
                        warmup=0)
    scale = DURATION_S / REFERENCE_S
    met = "met" if fast_cpu < GOAL_S else "NOT met"
    record_ratio(
        "VCA 400 s @1 kHz vs SciPy Radau", fast_cpu, ref_cpu * scale,
        n_samples=rec.n_samples,
        extra=(f"400 s in {fast_cpu:.2f} s CPU / {fast_wall:.2f} s wall (goal < {GOAL_S:g} s: "
               f"{met}); SciPy ran {REFERENCE_S:g} s, scaled x{scale:g}"),
    )
