"""The VCA's no-load size when only the end of a long recording leaks (a session-27 study).

Usage: ``python perf/flow_balance_long_run_size.py`` (about 2 min; run it alone, e.g. under
the heavy-job lock). docs/detect.md 8.5 quotes one run.

Machines 17 and 31, each fitted on six of its own healthy 120-s runs without load
(``false_alarms_per_hour=3``); 1-h runs with a 0.02 L/min step leak from 3000 s (seeds 5-8),
judged at the run level (:meth:`FlowBalanceDetector.run_level`), with the transducers'
differential zero error profiled in the size (leakdiag's behaviour) and without
(``_flow_balance_vca.OFFSET_PROFILED_LOADS`` emptied, as before 2026-11-29). Prints per run the
alarm, the size over the true mean leak since the onset, the interval likewise and the offset
found.
"""
import leakdiag as ld
import leakdiag.detect._flow_balance_vca as vca_backend
from leakdiag.detect import FlowBalanceDetector
from leakdiag.detect.flow_balance import RefusedAlarm


def main() -> None:
    for m in (17, 31):
        fit = [ld.sim.simulate_vca(duration=120, leak_lpm=0.0, load="none", machine=m, seed=s)
               for s in range(6)]
        det = FlowBalanceDetector(system="vca", false_alarms_per_hour=3.0).fit(fit)
        for seed in range(5, 9):
            rec = ld.sim.simulate_vca(duration=3600, leak_lpm=0.02, onset=3000, load="none",
                                      machine=m, seed=seed)
            truth = rec.meta["leak_lpm_achieved"]
            level = det.run_level(rec.duration - det.burn_in_s)
            out = [f"machine {m} seed {seed}"]
            for mode, name in ((("none", None), "profiled"), ((), "not profiled")):
                vca_backend.OFFSET_PROFILED_LOADS = mode
                try:
                    v = det.predict(rec, level=level[0] if level else None)
                except RefusedAlarm as e:
                    out.append(f"{name}: refused ({type(e).__name__})")
                    continue
                if v.leak_lpm is None:
                    out.append(f"{name}: leak {v.leak}, no size")
                    continue
                lo, hi = v.leak_lpm_interval
                off = ("" if v.pressure_offset_pa is None
                       else f", offset {v.pressure_offset_pa / 1e3:+.1f} kPa")
                out.append(f"{name}: alarm {v.alarm_time_s:.1f} s, size {v.leak_lpm / truth:.3f}x "
                           f"[{lo / truth:.2f}, {hi / truth:.2f}]{off}")
            vca_backend.OFFSET_PROFILED_LOADS = ("none", None)
            print("; ".join(out), flush=True)


if __name__ == "__main__":
    main()
