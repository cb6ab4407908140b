"""What the library reports, in the command line's words (options, not Python keywords).

The detectors' messages are written for the Python API (``burn_in_s=``, ``ReferenceMaxima``);
``fit`` and ``detect`` say the same in terms of their own options. :func:`option_names` writes
a message's ``name=value`` arguments as a command's options (``simulate``, ``analyze``).
"""

from __future__ import annotations

__all__ = ["threshold_words", "in_cli_words", "check_longer_than_burn_in", "option_names",
           "few_healthy_words", "MODEL_LEVEL_WORDS"]

#: What a model-based level did on virtual machines (docs/detect.md section 6), said under every
#: model-based flow-balance level by ``fit`` and ``detect``.
MODEL_LEVEL_WORDS = (
    "a model-based level can misjudge a unit: on 8 virtual machines each fitted on 4 healthy "
    "120-s no-load runs, one unit's healthy 30-min runs crossed its run level in 6 of 10, "
    "against about 0.097 stated per run by the model (the other 7 units: 0 of 70); fitted on 16 "
    "runs, where the level was distribution-free, 0 of 80 (docs/detect.md section 6, 'Does the "
    "run level keep its promise?'): give more healthy recordings where the rate matters")

#: The detectors' advice when healthy data cannot support a rate (detect/threshold.py), and
#: what a command-line user can do instead (reference maxima are a Python-API feature).
_API_ADVICE = "Give more healthy recordings, reference maxima from other units, or a larger target"
_CLI_ADVICE = ("Give more --healthy recordings (or longer ones), or a larger --false-alarm-rate")


def option_names(message: str, options: dict[str, str]) -> str:
    """A library message with its ``name=value`` arguments written as a command's options.

    The library's messages name the offending value as Python writes it (``window=1 must be
    >= 2``, house style); a command-line user gave an option. Only whole argument names are
    replaced (``start_window=`` is not ``window=``; ``lag=`` is not ``lag_ratio=``).

    Parameters
    ----------
    message : str
        The message.
    options : dict of str to str
        Python argument name -> option, e.g. ``{"window": "--window"}``.

    Returns
    -------
    str
        ``message`` with every ``name=`` of ``options`` written ``option `` (a space instead
        of ``=``).

    Examples
    --------
    >>> option_names("window=1 must be >= 2", {"window": "--window"})
    '--window 1 must be >= 2'
    >>> option_names("lag_ratio='9:3': l=9 must be < window=5; start_window=3",
    ...              {"lag": "--lag", "lag_ratio": "--lag-ratio", "window": "--window"})
    "--lag-ratio '9:3': l=9 must be < --window 5; start_window=3"
    """
    import re

    if not options:
        return message
    names = sorted(options, key=len, reverse=True)  # the longest first: lag_ratio before lag
    return re.sub(r"\b(" + "|".join(map(re.escape, names)) + r")=",
                  lambda m: options[m.group(1)] + " ", message)


def threshold_words(basis) -> str:
    """A detector's threshold basis (``Detector.threshold_basis_``) as one sentence.

    Parameters
    ----------
    basis : ThresholdBasis or None
        The basis.

    Returns
    -------
    str
        ``str(basis)`` (:meth:`ThresholdBasis.__str__`): threshold, rank among the healthy
        maxima, segment length and the false-alarm rate it guarantees (or that it guarantees
        nothing); "" for None.

    Examples
    --------
    >>> from leakdiag.detect.threshold import conformal_threshold
    >>> threshold_words(conformal_threshold([3.0, 1.0, 2.0, 5.0, 4.0], 0.4, segment_s=60.0))
    ... # doctest: +NORMALIZE_WHITESPACE
    '4 = the 2nd largest of 5 healthy CUSUM maxima (5 own; 60-s segments): at most 0.333 false
    alarm(s) per segment, i.e. 20 per hour (requested 24 per hour; 95 % upper bound for this very
    threshold 0.657 per segment)'
    """
    return "" if basis is None else str(basis)


def in_cli_words(message: str) -> str:
    """A detector's fitting error with the advice a command-line user can follow.

    Parameters
    ----------
    message : str
        The error message.

    Returns
    -------
    str
        ``message`` with Python-API advice and keyword names replaced by the options of
        ``fit``/``detect``.

    Examples
    --------
    >>> in_cli_words("3 maxima. " + _API_ADVICE)
    '3 maxima. Give more --healthy recordings (or longer ones), or a larger --false-alarm-rate'
    >>> in_cli_words("fit: only 0 finite feature values after burn_in_s=5.0")
    'fit: only 0 finite feature values after --burn-in 5.0 s'
    >>> in_cli_words("false_alarms_per_hour=100.0 is one or more alarms per 85 s segment: "
    ...              "choose a smaller target or segment_s")  # doctest: +NORMALIZE_WHITESPACE
    '--false-alarm-rate 100 (per hour) is one or more alarms per 85 s segment: choose a smaller
    --false-alarm-rate (a segment is a healthy recording after the burn-in)'
    """
    import re

    message = message.replace(_API_ADVICE, _CLI_ADVICE)
    message = message.replace("choose a smaller target or segment_s",
                              "choose a smaller --false-alarm-rate (a segment is a healthy "
                              "recording after the burn-in)")
    message = re.sub(r"false_alarms_per_hour=([0-9.eE+-]+)",
                     lambda m: f"--false-alarm-rate {float(m.group(1)):g} (per hour)", message)
    return re.sub(r"burn_in_s=([0-9.eE+-]+)", r"--burn-in \1 s", message)


def check_longer_than_burn_in(recordings, paths, burn_in_s: float) -> None:
    """Refuse healthy recordings that the burn-in would leave empty, naming file and option.

    Parameters
    ----------
    recordings : sequence of Recording
        Healthy recordings.
    paths : sequence of str
        Their files (for the message).
    burn_in_s : float
        ``--burn-in`` (s).

    Raises
    ------
    ValueError
        For the first recording not longer than the burn-in.
    """
    for p, r in zip(paths, recordings):
        if r.duration <= burn_in_s:
            raise ValueError(f"--healthy {p}: {r.duration:g} s long, not longer than --burn-in "
                             f"{burn_in_s:g} s, so nothing of it is left to fit on; give longer "
                             "healthy recordings or a shorter --burn-in")


def few_healthy_words(n: int) -> str | None:
    """What fewer than 4 healthy recordings cost the flow balance, or None from 4 on.

    Its own GLR maxima and its check of the healthy recordings against each other
    (``ODD_ONE_OUT_FACTOR``: a leaking run or another machine's among them) both come from
    two-fold cross-fitting, which needs 4 (a CLI audit, 2026-11-28, finding 2: ``detect
    --healthy`` with 3 files said neither).

    Parameters
    ----------
    n : int
        Healthy recordings given.

    Returns
    -------
    str or None

    Examples
    --------
    >>> few_healthy_words(4) is None
    True
    >>> few_healthy_words(3)[:64]
    'the flow balance cross-fits its healthy recordings from 4 on (go'
    """
    if n >= 4:
        return None
    return (f"the flow balance cross-fits its healthy recordings from 4 on (got {n}): its level "
            "has no healthy GLR maxima of its own (model-based), and the recordings are not "
            "checked against each other, so a leaking run or another machine's among them "
            "goes unnoticed and hides leaks of its size; give 4 or more (16 where the "
            "false-alarm rate matters)")
