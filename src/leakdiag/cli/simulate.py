"""``leakdiag simulate vca|eha``: simulate an actuator experiment to a recording file."""

from __future__ import annotations

import math
from pathlib import Path

import click

from leakdiag.cli._options import FiniteFloat
from leakdiag.sim.leak import LPM_PER_M3S

__all__ = ["simulate", "plot_simulation"]


def plot_simulation(rec, path):
    """Save the figure of a simulated run (like thesis Figs. 4-3, 4-4, 4-9, 4-10).

    Panels: reference and actual position (mm), control signal, both chamber pressures (MPa)
    and the true leak flow (L/min).

    Parameters
    ----------
    rec : Recording
        A simulated recording (channels ``x``, ``u``, ``p1``, ``p2``; ``x_ref`` and
        ``leak_flow`` if present).
    path : str or pathlib.Path
        Image file to write (format from the extension, e.g. ``.png``).

    Returns
    -------
    pathlib.Path
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = rec.time
    fig, axes = plt.subplots(4, 1, figsize=(10, 9), sharex=True)
    if "x_ref" in rec:
        axes[0].plot(t, rec["x_ref"] * 1e3, lw=0.8, label="reference")
    axes[0].plot(t, rec["x"] * 1e3, lw=0.8, label="actual")
    axes[0].set_ylabel("position (mm)")
    axes[0].legend(loc="upper right")
    axes[1].plot(t, rec["u"], lw=0.6, color="tab:green")
    axes[1].set_ylabel(f"control u ({rec.units.get('u', 'V')})")
    axes[2].plot(t, rec["p1"] / 1e6, lw=0.6, label="P1")
    axes[2].plot(t, rec["p2"] / 1e6, lw=0.6, label="P2")
    axes[2].set_ylabel("pressure (MPa)")
    axes[2].legend(loc="upper right")
    if "leak_flow" in rec:
        axes[3].plot(t, rec["leak_flow"] * LPM_PER_M3S, lw=0.6, color="tab:red")
    axes[3].set_ylabel("leak flow (L/min)")
    axes[3].set_xlabel("time (s)")
    onset = rec.onset
    for ax in axes:
        if onset is not None:
            ax.axvline(onset, color="k", ls=":", lw=0.8)
        ax.grid(alpha=0.3)
    m = rec.meta
    fig.suptitle(f"{str(m.get('system', '')).upper()} simulation: target "
                 f"{m.get('leak_lpm', 0):.3g} L/min, achieved "
                 f"{m.get('leak_lpm_achieved', 0):.3g} L/min, seed {m.get('seed')}")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


@click.command(epilog="Example: leakdiag simulate vca --duration 400 --onset 200 --leak 0.1 "
                      "--seed 1 -o run.parquet --plot")
@click.argument("system", type=click.Choice(["vca", "eha"]))
@click.option("--duration", type=FiniteFloat(min=0, min_open=True), default=None,
              help="Run length in s [default: 400 for vca, 180 for eha (Secs. 4.5, 4.6)].")
@click.option("--onset", type=FiniteFloat(min=0), default=None,
              help="Leak onset in s [default: half of --duration, as in Secs. 4.5, 4.6: 200 "
                   "for vca, 90 for eha].")
@click.option("--leak", "leak_lpm", type=FiniteFloat(min=0), default=None,
              help="Target mean leak after onset in L/min (0 = none) "
                   "[default: 0.1 for vca, 1.2 for eha].")
@click.option("--leak-model", type=click.Choice(["turbulent", "laminar"]), default="turbulent",
              show_default=True, help="Eq. 2-4 or Eq. 2-5 (the EHA has Eq. 2-4 only).")
@click.option("--leak-kind", type=click.Choice(["step", "ramp"]), default="step",
              show_default=True, help="Leak switched on at the onset, or ramped up over "
                                      "--ramp-duration.")
@click.option("--ramp-duration", type=FiniteFloat(min=0, min_open=True), default=None,
              help="Ramp length in s (with --leak-kind ramp) [default: 100 for vca, 30 for eha].")
@click.option("--load", type=click.Choice(["spring", "none"]), default="none", show_default=True,
              help="Load on the piston: a spring (Sec. 4.5; its stiffness is a choice, docs/models.md: Table 2-1 gives none) or none.")
@click.option("--seed", type=click.IntRange(min=0), default=1, show_default=True,
              help="Seed of the sensor noise and the VCA's reference sequence (the EHA's "
                   "open-loop input is the fixed 3 sin 4t).")
@click.option("--machine", type=click.IntRange(min=0), default=None,
              help="Draw virtual machine unit N (its tolerances: valve or pump, supply, bulk "
                   "modulus, transducers; docs/models.md); default: the nominal Table 2-1 / 3-1 "
                   "unit. The same N is the same unit whatever --seed.")
@click.option("--sample-rate", type=FiniteFloat(min=0, min_open=True), default=1000.0,
              show_default=True,
              help="Sample rate of the recording (Hz).")
@click.option("--no-sensors", is_flag=True, help="Record true, noise-free states.")
@click.option("--params", "params_file", type=click.Path(exists=True, dir_okay=False),
              default=None, help="TOML file overriding Table 2-1 (vca) or Table 3-1 (eha) "
                                 "parameters.")
@click.option("--out", "-o", type=click.Path(dir_okay=False), default="run.parquet", show_default=True,
              help="Output recording (.parquet, .csv, .h5).")
@click.option("--plot", is_flag=True, help="Also save a figure next to --out (.png).")
@click.option("--no-progress", is_flag=True, help="Hide the progress bar.")
def simulate(system, duration, onset, leak_lpm, leak_model, leak_kind, ramp_duration, load,
             seed, machine, sample_rate, no_sensors, params_file, out, plot, no_progress):
    """Simulate a VCA or EHA experiment with a leak and write the recording.

    Without --onset the leak starts at half of the run (--duration), as in the thesis's
    experiments (400 s / 200 s on the VCA, 180 s / 90 s on the EHA).
    """
    from tqdm import tqdm

    import leakdiag as ld
    from leakdiag.sim.eha.simulate import DEFAULT_DURATION_S as EHA_DURATION_S
    from leakdiag.sim.vca.simulate import DEFAULT_DURATION_S as VCA_DURATION_S

    if ramp_duration is not None and leak_kind != "ramp":
        raise click.UsageError("--ramp-duration applies to ramp leaks: add --leak-kind ramp")
    if system == "eha" and leak_model == "laminar":
        raise click.UsageError("--leak-model laminar: the EHA's leak is the thesis's turbulent "
                               "needle-valve flow, Eq. 2-4, only")
    # One signature for both rigs (keyword-only, same names): only what the user gave is
    # passed, every other argument keeps the rig's own default.
    kwargs = dict(seed=seed, sensors=not no_sensors, sample_rate=sample_rate, load=load,
                  leak_kind=leak_kind, leak_model=leak_model)
    for name, value in (("duration", duration), ("onset", onset), ("leak_lpm", leak_lpm),
                        ("ramp_duration", ramp_duration), ("machine", machine)):
        if value is not None:
            kwargs[name] = value
    fn = ld.sim.simulate_vca if system == "vca" else ld.sim.simulate_eha
    if params_file is not None:
        cls = ld.sim.VCAParams if system == "vca" else ld.sim.EHAParams
        kwargs["params"] = _params_from_toml(cls, params_file)

    run_s = duration if duration is not None else (
        VCA_DURATION_S if system == "vca" else EHA_DURATION_S)
    if not math.isfinite(run_s * sample_rate):  # two finite numbers, an infinite product
        raise click.UsageError(f"--duration {run_s:g} s at --sample-rate {sample_rate:g} Hz: "
                               "too many samples to count")
    total = int(round(run_s * sample_rate))
    _check_memory(system, run_s, sample_rate, total)
    bar = tqdm(total=total, unit="sample", desc=f"{system} run 1", leave=False,
               disable=no_progress)
    runs = [1]

    def progress(n_done):
        if bar.n + n_done > bar.total:
            runs[0] += 1
            bar.reset()
            bar.set_description(f"{system} run {runs[0]} (leak calibration)")
        bar.update(n_done)

    kwargs["progress"] = progress
    try:
        rec = fn(**kwargs)
    except ld.sim.LeakCalibrationError as exc:  # the sim's advice names Python arguments
        raise ld.sim.LeakCalibrationError(_option_names(
            _in_option_words(str(exc), run_s, onset if onset is not None else run_s / 2))
        ) from None
    except ValueError as exc:
        raise ValueError(_option_names(str(exc))) from None
    finally:
        bar.close()
    path = ld.io.write_recording(rec, out)
    m = rec.meta
    unit = (m.get("machine") or {}).get("unit")
    what = (f"leak target {m.get('leak_lpm', 0):.4g} L/min, achieved "
            f"{m.get('leak_lpm_achieved', 0):.4g} L/min, onset {m.get('onset'):g} s"
            if m.get("onset") is not None else "no leak")
    if m.get("onset") is None and onset is not None:
        what += f" (--onset {onset:g} ignored: no leak to start)"
    if m.get("leak_kind") == "ramp" and m.get("onset") is not None \
            and m["onset"] + m["ramp_duration"] > rec.duration:
        what += (f"; the {m['ramp_duration']:g}-s ramp from {m['onset']:g} s outlasts the run "
                 f"({rec.duration:g} s): the leak still rises at its end, and the target is its "
                 "mean after the onset")
    click.echo(f"wrote {path} ({rec.n_samples} samples at {rec.sample_rate:g} Hz, "
               f"{'nominal unit' if unit is None else f'machine unit {unit}'}, load "
               f"{m.get('load')}); {what}")
    if plot:
        fig = plot_simulation(rec, Path(out).with_suffix(".png"))
        click.echo(f"wrote {fig}")


#: Peak memory of one simulated run per sample, bytes: 168-169 (VCA, 6 channels) and 272-309
#: (EHA, 8 channels; with a leak the most) measured with ``tracemalloc`` on 20- and 40-s runs at
#: 1000 Hz (2026-11-27), rounded up, plus the writer's copy of the channels (8 bytes each).
BYTES_PER_SAMPLE = {"vca": 200 + 6 * 8, "eha": 350 + 8 * 8}


def _check_memory(system: str, run_s: float, rate: float, n: int) -> None:
    """Refuse a run that cannot fit in this machine's memory before it starts (a 10-s EHA
    run at 10 MHz worked for minutes towards 40 GiB, a longer one towards a MemoryError)."""
    from leakdiag.runtime.memory import memory_bytes, size_words

    need, have = n * BYTES_PER_SAMPLE[system], memory_bytes()
    if need > have:
        raise click.UsageError(
            f"--duration {run_s:g} s at --sample-rate {rate:g} Hz is {n:.3g} samples, which "
            f"need about {size_words(need)} of memory ({BYTES_PER_SAMPLE[system]} bytes per "
            f"sample); this machine has {size_words(have)}: give at most "
            f"{math.floor(have / BYTES_PER_SAMPLE[system] / rate):d} s at this rate")


#: The simulator's advice for a run too short to calibrate its leak
#: (:func:`leakdiag.sim.calibration.too_short_to_calibrate`), in Python argument words.
_PYTHON_ADVICE = ("Make the run longer or the onset earlier, or give leak_coefficient= instead "
                  "of leak_lpm.")


def _in_option_words(message: str, run_s: float, onset_s: float) -> str:
    """The simulator's calibration message with its advice in this command's options.

    ``simulate_vca/eha(leak_coefficient=...)`` has no option here, so the advice names
    ``--duration`` and ``--onset`` with the values of this run and the seconds needed after
    the onset. Other messages are returned as they are.

    Examples
    --------
    >>> _in_option_words("too short. " + _PYTHON_ADVICE + " (x)", 3.0, 1.5)  # doctest: +ELLIPSIS
    'too short. Give a longer --duration or an earlier --onset: at least 10 s must follow ...'
    """
    from leakdiag.sim.calibration import MIN_CALIBRATION_WINDOW_S

    if _PYTHON_ADVICE not in message:
        return message
    return message.replace(
        _PYTHON_ADVICE,
        f"Give a longer --duration or an earlier --onset: at least {MIN_CALIBRATION_WINDOW_S:g} "
        f"s must follow the onset (now --duration {run_s:g} with the onset at {onset_s:g} s "
        f"leaves {run_s - onset_s:g} s), e.g. --duration {onset_s + MIN_CALIBRATION_WINDOW_S:g}; "
        "or --leak 0 for a run without a leak.")


#: The simulators' keyword arguments that are options of this command.
_OPTION_OF = {"duration": "--duration", "onset": "--onset", "leak_lpm": "--leak",
              "ramp_duration": "--ramp-duration", "sample_rate": "--sample-rate",
              "machine": "--machine", "seed": "--seed"}


def _option_names(message: str) -> str:
    """A simulator message with its ``name=value`` arguments written as this command's options.

    Examples
    --------
    >>> _option_names("onset=20.0 s must lie in [0, duration=10.0) s")
    '--onset 20.0 s must lie in [0, --duration 10.0) s'
    >>> _option_names("leak_lpm=50.0 must be below the rated flow; ramp_duration=3")
    '--leak 50.0 must be below the rated flow; --ramp-duration 3'
    """
    from leakdiag.cli._words import option_names

    return option_names(message, _OPTION_OF)


def _params_from_toml(cls, path):
    """``cls.from_toml(path)``; a TOML syntax error names the file."""
    import tomllib

    try:
        return cls.from_toml(path)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: invalid TOML: {exc}") from None
