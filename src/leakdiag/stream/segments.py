"""A stream judged in consecutive segments by a whole-recording detector (the flow balance).

The chamber flow balance (:class:`~leakdiag.detect.FlowBalanceDetector`) and the other
whole-recording detectors (EKF, combined, wavelet, FFT, EMD) judge a recording with
``predict``: they fit the recording's own nuisance (the valve's null offset and drift) on all its
windows, so they have no window-by-window score a stream could update. :class:`SegmentJudge`
cuts the stream into consecutive, non-overlapping segments of ``segment_s`` seconds and judges
each one as ``leakdiag detect`` judges a file (decision 2026-11-28, docs/operations.md,
"Whole-recording detectors"): a decision reaches the console at most one segment after the
samples, and every segment is judged afresh, so the detector's false-alarm promise per run
holds per segment. The last, shorter segment is judged when the input ends (or said to be too
short).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from leakdiag._format import seconds
from leakdiag.detect.base import TooShortToJudge
from leakdiag.detect.decision import judge_run
from leakdiag.detect.flow_balance import AlarmAtStart, AlarmNotConfirmed, RefusedAlarm
from leakdiag.io.errors import RecordingError
from leakdiag.io.recording import Recording

__all__ = ["judges_whole", "SegmentJudge", "SegmentVerdict", "DEFAULT_SEGMENT_S"]

#: Default segment length (s): a decision at most a minute after the samples; the flow
#: balance's first windows of every segment (its 2-s burn-in and 5 windows of history) then
#: are about an eighth of it (leakdiag choice).
DEFAULT_SEGMENT_S = 60.0


def judges_whole(det: Any) -> bool:
    """Whether a detector judges a whole recording (``predict``) but cannot be streamed (no
    feature ``spec``): the flow balance, the EKF, the combined and literature detectors.

    Parameters
    ----------
    det : object
        A detector (fitted: it has ``threshold_``).

    Returns
    -------
    bool

    Examples
    --------
    >>> from leakdiag.detect import FlowBalanceDetector
    >>> judges_whole(FlowBalanceDetector())  # not fitted: no threshold
    False
    """
    return (not callable(getattr(det, "spec", None)) and callable(getattr(det, "predict", None))
            and hasattr(det, "threshold_"))


@dataclass(frozen=True)
class SegmentVerdict:
    """The judgement of one segment.

    Attributes
    ----------
    start_s, end_s : float
        Time of the segment's first sample and one sample after its last (s).
    verdict : Verdict or None
        The detector's verdict; None when it could not judge the segment or judged it
        inconclusive.
    reason : str or None
        Why not (the detector's ``RecordingError``), or why inconclusive.
    inconclusive : bool, default False
        The detector judged the segment and alarmed, but the alarm is no evidence of a leak:
        it refused the alarm itself (:class:`~leakdiag.detect.flow_balance.RefusedAlarm`: no
        lasting leak after it, or a leak fitted into the null offset from the segment's start)
        or the segment's length makes it likely by chance
        (:func:`leakdiag.detect.decision.judge_run`). ``leakdiag detect`` and ``batch`` read
        such a file INCONCLUSIVE, and so does this segment (a review, 2026-11-29: it read NOT
        JUDGED, and a stream of such segments ended with "no segment could be judged").
    too_short : bool, default False
        Not judged because the segment is too short for the detector
        (:class:`~leakdiag.detect.base.TooShortToJudge`): usually the input's last segment.
    continues_from_onset_s : float or None
        For a LEAK segment right after a LEAK segment: the onset found when the leak was first
        found (also on an INCONCLUSIVE segment there whose alarm the detector refused as at its
        start, :class:`~leakdiag.detect.flow_balance.AlarmAtStart`). The leak was then present
        when this segment began, so this segment's own onset is no onset (an audit, 2026-11-28:
        3 of 20 such segments were given a definite onset 6-26 s into the segment).
    continues_onset_censored : bool, default False
        Whether that onset is only "at or before" (the first segment's ``onset_censored``): a
        store audit, 2026-11-29, found the continuing segment's stored alarm without it.
    unconfirmed_alarm_s, unconfirmed_onset_s : float or None
        For a LEAK segment (not a continuing one) right after a segment whose alarm was not
        confirmed (:class:`~leakdiag.detect.flow_balance.AlarmNotConfirmed`: too little data
        after it): that alarm and its onset. A leak that began near a segment's end is refused
        there and found in the next segment after its burn-in, whose onset is then only "at or
        before" its first windows (a CLI audit, 2026-11-28, finding 8: a leak from 58 s was
        reported "at or before 65.1 s", with no word of the alarm at 58.2 s).
    """

    start_s: float
    end_s: float
    verdict: Any = None
    reason: str | None = None
    inconclusive: bool = False
    too_short: bool = False
    continues_from_onset_s: float | None = None
    continues_onset_censored: bool = False
    unconfirmed_alarm_s: float | None = None
    unconfirmed_onset_s: float | None = None

    @property
    def decision(self) -> str:
        """``"LEAK"``, ``"NO LEAK"``, ``"INCONCLUSIVE"`` or ``"NOT JUDGED"``."""
        if self.inconclusive:
            return "INCONCLUSIVE"
        if self.verdict is None:
            return "NOT JUDGED"
        return "LEAK" if self.verdict.leak else "NO LEAK"

    def to_json(self) -> str:
        """One JSON line: the segment, its decision and the verdict's fields (NaN as null).

        Returns
        -------
        str
        """
        d = {"segment_start_s": self.start_s, "segment_end_s": self.end_s,
             "decision": self.decision, "reason": self.reason,
             "continues_from_onset_s": self.continues_from_onset_s,
             "continues_onset_censored": self.continues_onset_censored,
             "unconfirmed_alarm_s": self.unconfirmed_alarm_s,
             "unconfirmed_onset_s": self.unconfirmed_onset_s}
        if self.verdict is not None:
            v = self.verdict.as_dict()
            d.update({k: v.get(k) for k in (
                "alarm_time_s", "onset_s", "onset_censored", "leak_lpm", "leak_lpm_low",
                "leak_lpm_high", "confidence", "score_max", "threshold", "detectable_lpm",
                "detectable_from_s")})
            d["p_value"] = d.pop("confidence")
            d["verdict"] = str(self.verdict)
        return json.dumps({k: (None if isinstance(x, float) and not math.isfinite(x) else x)
                           for k, x in d.items()})

    def words(self) -> str:
        """One console line.

        Returns
        -------
        str
        """
        span = f"{seconds(self.start_s, 6)}-{seconds(self.end_s, 6)} s"
        v = self.verdict
        if v is None:
            return f"{self.decision:<10} {span}: {self.reason}"
        if not v.leak:
            seen = getattr(v, "detectable_lpm", None)
            since = getattr(v, "detectable_from_s", None)
            return (f"NO LEAK    {span}: score max {v.score_max:.3g} against {v.threshold:.3g}"
                    + (f"; a step leak of {seen:.3g} L/min or more from "
                       f"{seconds(since, 6)} s would "
                       "have alarmed (probability about 0.9)" if seen is not None else ""))
        at = "at or before " if v.onset_censored else ""
        if self.continues_from_onset_s is not None:  # present when the segment began
            size = "" if v.leak_lpm is None else f", {v.leak_lpm:.3g} L/min in this segment"
            bound = "at or before " if self.continues_onset_censored else ""
            return (f"LEAK       {span}: the leak continues (found with onset {bound}"
                    f"{seconds(self.continues_from_onset_s, 6)} s){size}")
        size = ""
        if v.leak_lpm is not None:
            size = f", {v.leak_lpm:.3g} L/min"
            if v.leak_lpm_interval is not None:
                size += f" ({v.leak_lpm_interval[0]:.3g}-{v.leak_lpm_interval[1]:.3g})"
        elif isinstance(getattr(v, "leak_lpm_interval_holds", None), str):
            size = f"; {v.leak_lpm_interval_holds}"  # why no size (a censored onset, ...)
        before = ("" if self.unconfirmed_alarm_s is None else
                  f"; the segment before alarmed at {seconds(self.unconfirmed_alarm_s, 6)} s "
                  f"(onset {seconds(self.unconfirmed_onset_s, 6)} s) with too little data after "
                  "it to confirm "
                  "a leak: the leak may have begun there")
        return (f"LEAK       {span}: alarm at {seconds(v.alarm_time_s, 6)} s, onset {at}"
                f"{seconds(v.onset_s, 6)} s{size}{before}")


class SegmentJudge:
    """Cut a stream of chunks into segments and judge each with a whole-recording detector.

    Parameters
    ----------
    detector : Detector
        Fitted (:func:`judges_whole`).
    channels : sequence of str
        The channels the chunks carry (at least the detector's).
    sample_rate : float
        Hz.
    start_time : float
        Time of the first sample (s).
    segment_s : float, default :data:`DEFAULT_SEGMENT_S`
        Segment length (s); rounded to whole samples.
    units : dict, optional
        The channels' units (None: SI, as a plain CSV is read).
    meta : dict, optional
        The input's metadata (``system``, ``load``, ``machine``: the detector checks them per
        segment, as it checks a file's).
    source : str, default ``"<stream>"``
        Input name: each segment is named ``SOURCE [START-END s]`` in the detector's messages.

    Raises
    ------
    ValueError
        For a segment shorter than 2 samples.
    """

    def __init__(self, detector, channels, sample_rate: float, start_time: float = 0.0,
                 segment_s: float = DEFAULT_SEGMENT_S, units: dict | None = None,
                 meta: dict | None = None, source: str = "<stream>"):
        self.detector = detector
        self.channels = list(channels)
        self.sample_rate = float(sample_rate)
        self.start_time = float(start_time)
        self.n_segment = int(round(float(segment_s) * self.sample_rate))
        if not self.n_segment >= 2:
            raise ValueError(f"segment_s={segment_s!r} is shorter than 2 samples at "
                             f"{sample_rate:g} Hz")
        self.units = dict(units) if units else None
        # the input's metadata as a read file carries it (system, load, machine: the detector
        # checks them), the source named per segment
        self.meta = {k: v for k, v in (meta or {}).items() if k != "source"}
        self.source = source
        self.n_samples_seen = 0
        self._parts: list[dict] = []
        self._n_buffered = 0
        self._first = 0  # index of the buffered segment's first sample
        self._leak_onset: float | None = None  # onset of the leak found in the last segment
        self._leak_onset_censored = False  # ... and whether it is only "at or before"
        # (alarm, onset) of the last segment's alarm that too little data confirmed
        self._unconfirmed: tuple[float, float] | None = None

    def push(self, chunk: dict) -> list[SegmentVerdict]:
        """Add a chunk; judge every segment it completes.

        Parameters
        ----------
        chunk : dict
            Channel name -> 1-D array, all of one length.

        Returns
        -------
        list of SegmentVerdict
        """
        n = len(chunk[self.channels[0]])
        self.n_samples_seen += n
        out = []
        at = 0
        while at < n:
            take = min(n - at, self.n_segment - self._n_buffered)
            self._parts.append({c: np.asarray(chunk[c][at:at + take], dtype=np.float64)
                                for c in self.channels})
            self._n_buffered += take
            at += take
            if self._n_buffered == self.n_segment:
                out.append(self._judge())
        return out

    def finish(self) -> SegmentVerdict | None:
        """Judge the last, shorter segment.

        Returns
        -------
        SegmentVerdict or None
            None when nothing is buffered.
        """
        return self._judge() if self._n_buffered else None

    def _judge(self) -> SegmentVerdict:
        chans = {c: np.concatenate([p[c] for p in self._parts]) for c in self.channels}
        n = self._n_buffered
        start = self.start_time + self._first / self.sample_rate
        end = start + n / self.sample_rate
        self._first += n
        self._parts, self._n_buffered = [], 0
        name = f"{self.source} [{start:.6g}-{end:.6g} s]"
        try:
            rec = Recording(chans, self.sample_rate, start, units=dict(self.units or {}),
                            meta={**self.meta, "source": name})
            # a segment longer than the detector's healthy one: judged at its run level, as
            # leakdiag detect judges a file (leakdiag.detect.decision.judge_run)
            j = judge_run(self.detector, rec)
        except RecordingError as exc:  # too short, a stuck channel, the model does not fit
            self._unconfirmed = (
                (exc.alarm_time_s, exc.onset_s) if isinstance(exc, AlarmNotConfirmed) else None)
            prior = self._leak_onset
            if isinstance(exc, AlarmAtStart) and prior is not None:  # the leak found before
                return SegmentVerdict(start, end, reason=(
                    f"{name}: the leak found with onset {prior:.6g} s was present when this "
                    f"segment began and alarmed again at {exc.alarm_time_s:.6g} s, but a leak "
                    f"present from a segment's start cannot be judged on that segment alone: "
                    f"{exc}"), inconclusive=True, continues_from_onset_s=prior,
                    continues_onset_censored=self._leak_onset_censored)
            return SegmentVerdict(start, end, reason=str(exc),
                                  inconclusive=isinstance(exc, RefusedAlarm),
                                  too_short=isinstance(exc, TooShortToJudge))
        unconfirmed, self._unconfirmed = self._unconfirmed, None
        v = j.verdict
        if j.decision == "inconclusive":  # an alarm the segment's length makes no evidence
            return SegmentVerdict(start, end, reason=(
                f"{name}: the detector alarmed (score {v.score_max:.3g} against "
                f"{v.threshold:.3g}), but {j.why_inconclusive}; use a shorter segment or a "
                "detector fitted for fewer false alarms per hour"), inconclusive=True)
        if not v.leak:
            self._leak_onset = None
            return SegmentVerdict(start, end, verdict=v)
        prior = self._leak_onset
        if prior is None:
            self._leak_onset = v.onset_s
            self._leak_onset_censored = bool(v.onset_censored)
        earlier = unconfirmed if prior is None else None
        return SegmentVerdict(start, end, verdict=v, continues_from_onset_s=prior,
                              continues_onset_censored=prior is not None
                              and self._leak_onset_censored,
                              unconfirmed_alarm_s=None if earlier is None else earlier[0],
                              unconfirmed_onset_s=None if earlier is None else earlier[1])
