"""Flow-balance detector when the other leak law is true (docs/detect.md, section 8.2).

Machine 17, 4 healthy runs of 60 s to fit, one leaking run per case (onset 30 s, seed 77).
About 30 CPU-seconds::

    python perf/flow_balance_leak_law.py
"""

import leakdiag as ld


def main():
    for load in ("spring", "none"):
        healthy = [ld.sim.simulate_vca(duration=60, leak_lpm=0.0, load=load, machine=17, seed=s)
                   for s in range(4)]
        for law in ("turbulent", "laminar"):
            det = ld.detect.FlowBalanceDetector(system="vca", leak_law=law).fit(healthy)
            for true_law in ("turbulent", "laminar"):
                for q in (0.005, 0.02):
                    rec = ld.sim.simulate_vca(duration=60, leak_lpm=q, onset=30, load=load,
                                              machine=17, seed=77, leak_model=true_law)
                    v = det.predict(rec)
                    ci = v.leak_lpm_interval and tuple(round(c, 4) for c in v.leak_lpm_interval)
                    print(f"{load:6s} assumed={law:9s} true={true_law:9s} q={q}: "
                          f"leak={v.leak} alarm={v.alarm_time_s} "
                          f"est={v.leak_lpm and round(v.leak_lpm, 4)} ci={ci} "
                          f"true={rec.meta['leak_lpm_achieved']:.4f} G={v.score_max:.1f}",
                          flush=True)


if __name__ == "__main__":
    main()
