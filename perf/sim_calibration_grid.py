"""Leak calibration over a grid of cases: post-onset runs, pilots, work and landing error.

Usage (run it alone, e.g. under the heavy-job lock; about a minute per grid)::

    python perf/sim_calibration_grid.py vca 400 200     # VCA without load, duration, onset
    python perf/sim_calibration_grid.py vca 120 60
    python perf/sim_calibration_grid.py eha

The VCA grid is seeds 0-5 x 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5 L/min without load (nominal
unit, the given duration and onset); the EHA grid is open and closed loop x no load and spring
x 0.1, 0.5, 1.2 L/min x seeds 1-2 (units 3-4), 180 s with the onset at 90 s, once with plain
conditions and once with the benchmark's (temperature rise, amplitude and frequency variation
0.05, a spring change at 100 s), plus 8 runs of the structured excitation. Work is host
independent: VCA samples x RK4 steps per sample, EHA accepted + rejected Rosenbrock steps, each
over the healthy run of the same arguments. docs/models.md ("Pilots revised") quotes it.
"""
import itertools
import sys

import numpy as np

import leakdiag as ld
from leakdiag.sim.eha import simulate as eha_simulate
from leakdiag.sim.eha.drive import EHAConditions
from leakdiag.sim.excitation import structured_excitation
from leakdiag.sim.vca import integrate as vca_integrate

_work: list[int] = []


def _instrument() -> None:
    advance = vca_integrate._SegmentedLoop.advance
    fast = eha_simulate.integrate_fast

    def logged_advance(self, carry, stop, n_sub, k_arr, out, chunk=None, callback=None):
        _work.append((stop - carry.index) * n_sub)
        advance(self, carry, stop, n_sub, k_arr, out, chunk, callback)

    def logged_fast(*args, **kw):
        sol = fast(*args, **kw)
        _work.append(sol.n_accepted + sol.n_rejected)
        return sol

    vca_integrate._SegmentedLoop.advance = logged_advance
    eha_simulate.integrate_fast = logged_fast


def _case(fn, leak_lpm, **kw):
    """(work of the leaking run / work of the healthy one, post-onset runs, pilots, error)."""
    _work.clear()
    fn(leak_lpm=None, **kw)
    healthy = sum(_work)
    _work.clear()
    rec = fn(leak_lpm=leak_lpm, **kw)
    m = rec.meta
    return (sum(_work) / healthy, m["calibration_runs"], m["calibration_pilot_runs"],
            m["leak_lpm_achieved"] / leak_lpm - 1)


def _summary(label, rows) -> None:
    w = np.array([r[1] for r in rows])
    runs = np.bincount([r[2] for r in rows])
    err = [r[4] for r in rows]
    print(f"{label}: {len(rows)} cases, work / healthy mean {w.mean():.3f} median "
          f"{np.median(w):.3f} worst {w.max():.3f}; post-onset runs "
          f"{ {i: int(c) for i, c in enumerate(runs) if c} }; pilots {sum(r[3] for r in rows)}; "
          f"error {min(err):+.4f} .. {max(err):+.4f}", flush=True)


def vca(duration: float, onset: float) -> None:
    sizes = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)
    rows = [(lk, *_case(ld.sim.simulate_vca, lk, duration=duration, onset=onset, load="none",
                        seed=seed))
            for seed, lk in itertools.product(range(6), sizes)]
    _summary(f"VCA {duration:g} s, no load", rows)
    for lk in sizes:
        sel = [r for r in rows if r[0] == lk]
        print(f"  {lk} L/min: runs {[r[2] for r in sel]}, work mean "
              f"{np.mean([r[1] for r in sel]):.3f}")


def eha() -> None:
    def bench(seed, load):
        spring = load == "spring"
        return EHAConditions(temperature_rise_k=3.0 + seed, amplitude_variation=0.05,
                             frequency_variation=0.05,
                             spring_change_time_s=100.0 if spring else None,
                             spring_change_factor=1.1 if spring else 1.0)

    for label, conditions in (("plain", None), ("benchmark conditions", bench)):
        rows = []
        for mode, load, lk, seed in itertools.product(("open-loop", "closed-loop"),
                                                      ("none", "spring"), (0.1, 0.5, 1.2), (1, 2)):
            kw = dict(duration=180.0, onset=90.0, mode=mode, load=load, seed=seed,
                      machine=seed + 2)
            if conditions is not None:
                kw["conditions"] = conditions(seed, load)
            rows.append((lk, *_case(ld.sim.simulate_eha, lk, **kw)))
        _summary(f"EHA 180 s, {label}", rows)
    rows = [(lk, *_case(ld.sim.simulate_eha, lk, input_signal=structured_excitation("eha"),
                        load=load, seed=seed))
            for load, seed, lk in itertools.product(("none", "spring"), (1, 2), (0.1, 1.2))]
    _summary("EHA structured excitation", rows)


if __name__ == "__main__":
    _instrument()
    if sys.argv[1:2] == ["eha"]:
        eha()
    else:
        vca(float(sys.argv[2]), float(sys.argv[3]))
