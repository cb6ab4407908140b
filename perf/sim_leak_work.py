"""Where a leaking simulation's time goes (a measuring script, not a test).

Run: ``PYTHONPATH=src python -m perf.sim_leak_work``. For each case of
``sim_leak_cost.py`` it lists the integrations a healthy and a leaking run perform and their work:
VCA, samples x RK4 steps per sample (the kernel's cost is proportional to it); EHA, accepted +
rejected Rosenbrock steps. The work does not depend on the host (CPU seconds are printed too).
"""

from __future__ import annotations

import time

import leakdiag as ld
from leakdiag.sim.eha import simulate as eha_simulate
from leakdiag.sim.vca import integrate as vca_integrate

from perf.sim_leak_cost import CASES

_log: list[tuple[str, int, float]] = []


def _instrument() -> None:
    """Wrap the two integrators so that every call is logged (label, work, CPU s)."""
    advance = vca_integrate._SegmentedLoop.advance
    fast = eha_simulate.integrate_fast

    def logged_advance(self, carry, stop, n_sub, k_arr, out, chunk=None, callback=None):
        t0, i0 = time.process_time(), carry.index
        advance(self, carry, stop, n_sub, k_arr, out, chunk, callback)
        _log.append((f"samples {i0}-{stop}, {n_sub} RK4 steps each, k={k_arr[0]:.4g}",
                     (stop - i0) * n_sub, time.process_time() - t0))

    def logged_fast(y0, inputs, params, sample_rate, **kw):
        t0 = time.process_time()
        sol = fast(y0, inputs, params, sample_rate, **kw)
        _log.append((f"{inputs.shape[0]} samples, rtol {kw.get('rtol'):.2g}",
                     sol.n_accepted + sol.n_rejected, time.process_time() - t0))
        return sol

    vca_integrate._SegmentedLoop.advance = logged_advance
    eha_simulate.integrate_fast = logged_fast


def main() -> None:
    _instrument()
    ld.sim.simulate_vca(duration=2.0, leak_lpm=0.1, onset=1.0, leak_coefficient=1e-8)
    ld.sim.simulate_eha(duration=2.0, leak_lpm=None)
    for system, kw, label in CASES:
        fn = ld.sim.simulate_vca if system == "vca" else ld.sim.simulate_eha
        _log.clear()
        fn(leak_lpm=None, **{k: v for k, v in kw.items() if k != "leak_lpm"})
        healthy = sum(w for _, w, _ in _log)
        _log.clear()
        rec = fn(**kw)
        leak = sum(w for _, w, _ in _log)
        m = rec.meta
        print(f"\n{label}: work {leak / healthy:.2f} x healthy, CPU "
              f"{sum(c for _, _, c in _log):.2f} s; post-onset runs {m['calibration_runs']}, "
              f"pilots {m['calibration_pilot_runs']}")
        for what, work, cpu in _log:
            print(f"    {what:55s} {work / healthy:5.2f} x healthy  {cpu:6.3f} s")


if __name__ == "__main__":
    main()
