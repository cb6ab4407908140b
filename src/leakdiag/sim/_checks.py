"""Argument checks shared by the experiment entry points :func:`~leakdiag.sim.simulate_vca` and
:func:`~leakdiag.sim.simulate_eha`.

Each check raises with the message the entry points have always raised, naming the value.
"""

from __future__ import annotations

import numpy as np

__all__ = ["check_choice", "check_leak_kind", "check_seed", "check_params_type",
           "n_samples", "check_onset"]


def check_choice(value, name: str, choices) -> None:
    """Check that ``value`` is one of ``choices``.

    Parameters
    ----------
    value : object
        The argument.
    name : str
        Its name, used in the message.
    choices : sequence
        Allowed values.

    Raises
    ------
    ValueError
        If ``value`` is not in ``choices``.

    Examples
    --------
    >>> check_choice("spring", "load", ("none", "spring"))
    >>> check_choice("mass", "load", ("none", "spring"))
    Traceback (most recent call last):
    ...
    ValueError: load='mass' must be one of ['none', 'spring']
    """
    if value not in choices:
        raise ValueError(f"{name}={value!r} must be one of {list(choices)}")


def check_leak_kind(leak_kind) -> None:
    """Check that ``leak_kind`` is ``"step"`` or ``"ramp"``.

    Parameters
    ----------
    leak_kind : str
        How the leak is switched on.

    Raises
    ------
    ValueError
        Otherwise.

    Examples
    --------
    >>> check_leak_kind("ramp")
    >>> check_leak_kind("pulse")
    Traceback (most recent call last):
    ...
    ValueError: leak_kind='pulse' must be 'step' or 'ramp'
    """
    if leak_kind not in ("step", "ramp"):
        raise ValueError(f"leak_kind={leak_kind!r} must be 'step' or 'ramp'")


def check_seed(seed) -> None:
    """Check that ``seed`` is a non-negative integer (``bool`` is refused).

    Parameters
    ----------
    seed : int
        Random seed of the experiment.

    Raises
    ------
    ValueError
        If ``seed`` is not a non-negative ``int`` or NumPy integer.

    Examples
    --------
    >>> check_seed(0)
    >>> check_seed(-1)
    Traceback (most recent call last):
    ...
    ValueError: seed=-1 must be a non-negative integer
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed={seed!r} must be a non-negative integer")


def check_params_type(value, cls: type, name: str = "params"):
    """Return ``cls()`` for ``None``, else ``value`` if it is a ``cls``.

    Parameters
    ----------
    value : cls or None
        The argument; ``None`` selects the default ``cls()``.
    cls : type
        Expected (frozen dataclass) type, constructible without arguments.
    name : str, default "params"
        Argument name, used in the message.

    Returns
    -------
    cls
        ``value`` or ``cls()``.

    Raises
    ------
    TypeError
        If ``value`` is neither ``None`` nor a ``cls``.

    Examples
    --------
    >>> from leakdiag.sim.vca.params import VCAParams
    >>> check_params_type(None, VCAParams) == VCAParams()
    True
    >>> check_params_type(1.0, VCAParams)
    Traceback (most recent call last):
    ...
    TypeError: params must be a VCAParams, got float
    """
    value = cls() if value is None else value
    if not isinstance(value, cls):
        article = "an" if cls.__name__[:1].upper() in "AEIOU" else "a"
        raise TypeError(f"{name} must be {article} {cls.__name__}, got {type(value).__name__}")
    return value


def n_samples(duration: float, sample_rate: float) -> int:
    """Number of samples of a run, ``round(duration * sample_rate)``, at least 2.

    Parameters
    ----------
    duration : float
        Run length, s (already checked positive).
    sample_rate : float
        Output rate, Hz (already checked positive).

    Returns
    -------
    int
        Sample count.

    Raises
    ------
    ValueError
        If the run has fewer than 2 samples.

    Examples
    --------
    >>> n_samples(2.0, 1000.0)
    2000
    """
    n = int(round(duration * sample_rate))
    if n < 2:
        raise ValueError(f"duration={duration} s at sample_rate={sample_rate} Hz gives fewer "
                         "than 2 samples")
    return n


def check_onset(onset, n: int, sample_rate: float, duration: float) -> float:
    """Check that the leak onset lies in the run, ``0 <= onset < (n - 1) / sample_rate``.

    Parameters
    ----------
    onset : float
        Leak onset, s.
    n : int
        Samples in the run.
    sample_rate : float
        Output rate, Hz.
    duration : float
        Run length, s (for the message).

    Returns
    -------
    float
        ``float(onset)``.

    Raises
    ------
    ValueError
        If the onset lies outside the run.

    Examples
    --------
    >>> check_onset(1, 2000, 1000.0, 2.0)
    1.0
    >>> check_onset(2.0, 2000, 1000.0, 2.0)
    Traceback (most recent call last):
    ...
    ValueError: onset=2 s must lie in [0, 1.999) s: before the run's last sample (2000 samples at 1000 Hz, duration=2 s)
    >>> check_onset(True, 2000, 1000.0, 2.0)
    Traceback (most recent call last):
    ...
    ValueError: onset=True must be a number of seconds, not a bool
    """
    # (a simulator audit, 2026-11-29: onset=True ran a leak from 1 s; and a message that named
    # [0, duration) refused 3.9995 s of a 4-s run, inside it: the bound is the last sample)
    if isinstance(onset, (bool, np.bool_)):
        raise ValueError(f"onset={onset!r} must be a number of seconds, not a bool")
    onset = float(onset)
    last = (n - 1) / sample_rate
    if not (0.0 <= onset < last):
        raise ValueError(f"onset={onset:g} s must lie in [0, {last:g}) s: before the run's last "
                         f"sample ({n} samples at {sample_rate:g} Hz, duration={duration:g} s)")
    return onset


def check_condition_numbers(conditions, optional: tuple = ()) -> None:
    """Check that every field of an operating-conditions object is a finite real number (numpy
    scalars included, bools not), or None for the fields in ``optional``.

    Parameters
    ----------
    conditions : dataclass instance
        :class:`~leakdiag.sim.vca.conditions.OperatingConditions` or
        :class:`~leakdiag.sim.eha.drive.EHAConditions`.
    optional : tuple of str
        Fields that may be None.

    Raises
    ------
    TypeError
        For a bool, text or None where a number is needed (naming the field).
    ValueError
        For a non-finite number.

    Examples
    --------
    >>> from leakdiag.sim.vca.conditions import OperatingConditions
    >>> OperatingConditions(spring_change_time_s=True)
    Traceback (most recent call last):
    ...
    TypeError: spring_change_time_s=True must be a number of seconds or None, not a bool
    """
    from dataclasses import fields

    from leakdiag._validation import check_number

    # (a simulator audit, 2026-11-29: EHAConditions(spring_change_time_s=True) changed the
    # spring at 1 s, temperature_rise_k="5" failed inside numpy, None with a bare TypeError;
    # OperatingConditions refused numpy's float32 as "not a finite number")
    for f in fields(conditions):
        v = getattr(conditions, f.name)
        if v is None and f.name in optional:
            continue
        check_number(v, f.name, what="a number of seconds or None" if f.name in optional
                     else "a number")
