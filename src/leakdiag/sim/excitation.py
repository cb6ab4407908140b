"""Structured test inputs: periodic steps and a repeated chirp (issue 6, "structured excitation").

Normal operation in the thesis is a pseudorandom step reference (VCA, Sec. 4.5) or ``3 sin 4t``
(EHA, Sec. 4.6). The best published EHA result (Thakur 2011: 0.0042 L/min, 85 % detection) came
from a *structured* test input instead: the same motion repeated, so that every analysis window
sees the same excitation and a change of the features can only come from the actuator.

Both inputs here are periodic with period ``period_s``; a window whose length is a whole number
of periods therefore covers the same input whatever its start. Each class has
``samples(time, rng) -> values`` like :mod:`leakdiag.sim.reference`, so it plugs into the VCA's
``reference`` option (values in m) and, sampled, into the EHA's input (values in V).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from leakdiag._validation import as_1d_float, check_positive

__all__ = ["PeriodicSteps", "RepeatedChirp", "structured_excitation", "EXCITATION_KINDS"]

#: Kinds accepted by :func:`structured_excitation`.
EXCITATION_KINDS = ("steps", "chirp")

VCA_STEP_AMPLITUDE_M = 10e-3  # choice: mid-range of the thesis's 2-18 mm steps (Sec. 4.5)
EHA_STEP_AMPLITUDE_V = 3.0  # choice: the amplitude of the thesis's 3 sin 4t input (Sec. 4.6)
STEP_PERIOD_S = 1.0  # choice: one period per default 1000-sample window at 1 kHz
#: choice: EHA steps start low for a quarter period, so that the open-loop stroke (the integral
#: of the pump flow) swings about mid-stroke, +-39 mm like 3 sin 4t, instead of 0 to +78 mm.
EHA_STEP_START_S = 0.25 * STEP_PERIOD_S
CHIRP_F0_HZ = 0.5  # choice: slow start of the sweep ...
CHIRP_F1_HZ = 5.0  # ... to 5 Hz, inside the closed-loop bandwidth of the simulated VCA


def _phase(t: np.ndarray, period: float, t0: float) -> np.ndarray:
    """Position inside the current period, in [0, period)."""
    return np.mod(t - t0, period)


@dataclass(frozen=True)
class PeriodicSteps:
    """Square wave: ``offset + amplitude`` for the first ``duty`` of each period, else minus.

    Parameters
    ----------
    amplitude : float, default 10e-3
        Step half-height, in the unit of the driven signal (m for a VCA position reference,
        V for an EHA command).
    period_s : float, default 1.0
        Period in s (one up step and one down step).
    offset : float, default 0.0
        Mean level (same unit as ``amplitude``) for ``duty = 0.5``.
    duty : float, default 0.5
        Fraction of the period at the high level, in (0, 1).
    start_s : float, default 0.0
        Time of the first rising edge, s.

    Raises
    ------
    ValueError
        If ``period_s`` is not positive or ``duty`` not in (0, 1).

    Notes
    -----
    .. math:: r(t) = c + a\\,\\mathrm{sgn}^{+}\\big(d\\,T - ((t - t_0) \\bmod T)\\big)

    with :math:`\\mathrm{sgn}^{+}(s) = 1` for :math:`s > 0`, else :math:`-1`.

    Examples
    --------
    >>> PeriodicSteps(1.0, period_s=2.0).samples(np.arange(0.0, 4.0, 0.5), None).tolist()
    [1.0, 1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0]
    """

    amplitude: float = VCA_STEP_AMPLITUDE_M
    period_s: float = STEP_PERIOD_S
    offset: float = 0.0
    duty: float = 0.5
    start_s: float = 0.0

    def __post_init__(self) -> None:
        check_positive(self.period_s, "period_s")
        if not (0.0 < float(self.duty) < 1.0):
            raise ValueError(f"duty={self.duty!r} must be in (0, 1)")
        for name in ("amplitude", "offset", "start_s"):
            if not np.isfinite(float(getattr(self, name))):
                raise ValueError(f"{name}={getattr(self, name)!r} must be finite")

    def samples(self, time, rng=None) -> np.ndarray:
        """Values at each time (s); ``rng`` is unused (the input is deterministic).

        Parameters
        ----------
        time : array_like
            Times in s.
        rng : numpy.random.Generator, optional
            Ignored; present for the :class:`leakdiag.sim.reference.Reference` protocol.

        Returns
        -------
        numpy.ndarray
            Input values, same shape as ``time``.
        """
        t = as_1d_float(time, "time")
        high = _phase(t, self.period_s, self.start_s) < self.duty * self.period_s
        return np.where(high, self.offset + self.amplitude, self.offset - self.amplitude)


@dataclass(frozen=True)
class RepeatedChirp:
    """Linear sine sweep from ``f0_hz`` to ``f1_hz``, restarted every ``period_s``.

    Parameters
    ----------
    amplitude : float, default 5e-3
        Amplitude, in the unit of the driven signal (m or V).
    f0_hz, f1_hz : float, default 0.5, 5.0
        Start and end frequencies of each sweep, Hz.
    period_s : float, default 4.0
        Duration of one sweep, s; choose ``f0_hz * period_s`` and ``f1_hz * period_s`` so that
        the sweep starts and ends near a zero crossing.
    offset : float, default 0.0
        Mean level.

    Raises
    ------
    ValueError
        If a frequency or the period is not positive.

    Notes
    -----
    With :math:`\\tau = t \\bmod T`:

    .. math:: r(t) = c + a \\sin\\big(2\\pi (f_0 \\tau + (f_1 - f_0)\\tau^2 / (2T))\\big)

    The sweep's phase at its end is :math:`\\pi T (f_0 + f_1)`; with the defaults it is
    :math:`22\\pi`, a whole number of cycles, so consecutive sweeps join without a jump.

    Examples
    --------
    >>> c = RepeatedChirp(1.0, f0_hz=1.0, f1_hz=1.0, period_s=1.0)
    >>> c.samples(np.array([0.25, 1.25]), None).round(12).tolist()
    [1.0, 1.0]
    """

    amplitude: float = 5e-3
    f0_hz: float = CHIRP_F0_HZ
    f1_hz: float = CHIRP_F1_HZ
    period_s: float = 4.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        check_positive(self.f0_hz, "f0_hz")
        check_positive(self.f1_hz, "f1_hz")
        check_positive(self.period_s, "period_s")
        for name in ("amplitude", "offset"):
            if not np.isfinite(float(getattr(self, name))):
                raise ValueError(f"{name}={getattr(self, name)!r} must be finite")

    def samples(self, time, rng=None) -> np.ndarray:
        """Values at each time (s); ``rng`` is unused.

        Parameters
        ----------
        time : array_like
            Times in s.
        rng : numpy.random.Generator, optional
            Ignored.

        Returns
        -------
        numpy.ndarray
            Input values, same shape as ``time``.
        """
        t = as_1d_float(time, "time")
        tau = _phase(t, self.period_s, 0.0)
        k = (self.f1_hz - self.f0_hz) / self.period_s
        return self.offset + self.amplitude * np.sin(
            2 * np.pi * (self.f0_hz * tau + 0.5 * k * tau**2))


def structured_excitation(system: str = "vca", kind: str = "steps"):
    """The documented structured test input of a rig.

    Parameters
    ----------
    system : {"vca", "eha"}, default "vca"
        ``"vca"``: a position reference in m for the closed-loop VCA. ``"eha"``: a command in V
        for the open-loop EHA.
    kind : {"steps", "chirp"}, default "steps"
        Periodic steps (1 s period, +-10 mm or +-3 V) or a repeated 0.5-5 Hz chirp (4 s sweeps,
        5 mm or 3 V). The EHA steps are -3 V for the first quarter period, then alternate
        every half period (+3 V from 0.25 s to 0.75 s, ...): the open-loop EHA integrates its
        command, so this keeps the piston swinging about mid-stroke (``docs/literature.md``).

    Returns
    -------
    PeriodicSteps or RepeatedChirp

    Raises
    ------
    ValueError
        For an unknown system or kind.

    Examples
    --------
    >>> structured_excitation("vca")
    PeriodicSteps(amplitude=0.01, period_s=1.0, offset=0.0, duty=0.5, start_s=0.0)
    >>> structured_excitation("eha", "chirp").amplitude
    3.0
    >>> structured_excitation("eha").samples(np.array([0.0, 0.25, 0.5, 0.75, 1.0])).tolist()
    [-3.0, 3.0, 3.0, -3.0, -3.0]
    """
    if system not in ("vca", "eha"):
        raise ValueError(f"system={system!r} must be 'vca' or 'eha'")
    if kind not in EXCITATION_KINDS:
        raise ValueError(f"kind={kind!r} must be one of {EXCITATION_KINDS}")
    if kind == "steps":
        if system == "vca":
            return PeriodicSteps(amplitude=VCA_STEP_AMPLITUDE_M, period_s=STEP_PERIOD_S)
        return PeriodicSteps(amplitude=EHA_STEP_AMPLITUDE_V, period_s=STEP_PERIOD_S,
                             start_s=EHA_STEP_START_S)
    amp = 5e-3 if system == "vca" else EHA_STEP_AMPLITUDE_V
    return RepeatedChirp(amplitude=amp)
