"""``monitor --method``: a streamable feature, or a method name of ``leakdiag fit -m``.

A detector file records the registry name it was fitted with (``ccf-p1p2``,
:data:`leakdiag.bench.registry.METHODS`); docs/operations.md promised that the monitor takes
the detector's method "under any of its names", but ``--method`` knew only the features, so
``monitor --detector det.joblib --method ccf-p1p2`` exited 2 (docs audit 2026-11-29). A fit
name stands for its feature *and* its channels: ``acf-p2`` is the autocorrelation of ``p2``, so
it is refused for an ``acf-p1`` detector, whose feature name alone (``autocorrelation``) would
have been accepted.
"""

from __future__ import annotations

import click

from leakdiag.cli._features import FeatureChoice

__all__ = ["MonitorMethod", "fit_method_feature", "resolve_method"]


def _fit_names() -> list[str]:
    from leakdiag.bench.registry import METHODS

    return sorted(METHODS)


class MonitorMethod(FeatureChoice):
    """A streamable feature's canonical name (aliases accepted), or a method name of ``leakdiag
    fit -m`` returned as given (:func:`resolve_method` reads it)."""

    def __init__(self):
        super().__init__(streamable=True)

    def convert(self, value, param, ctx):
        """The feature's canonical name, or ``value`` itself when ``fit -m`` takes it.

        Returns
        -------
        str
        """
        try:
            return super().convert(value, param, ctx)
        except click.BadParameter:
            names = _fit_names()  # (the registry imports the detectors: only when needed)
            if value in names:
                return value
            self.fail(f"{value!r} is not one of {', '.join(map(repr, self.choices()))}, nor a "
                      f"method of leakdiag fit -m ({', '.join(names)})", param, ctx)


def fit_method_feature(name: str) -> tuple[str, tuple[str, ...]] | None:
    """The feature and channels a ``fit -m`` method monitors, None for one that is not a single
    feature (``combined``, the literature's methods, ``flow-balance``).

    Parameters
    ----------
    name : str
        A key of :data:`leakdiag.bench.registry.METHODS`.

    Returns
    -------
    tuple of (str, tuple of str) or None
        Canonical feature name and channels.

    Examples
    --------
    >>> fit_method_feature("ccf-p1p2")
    ('cross-correlation', ('p1', 'p2'))
    >>> fit_method_feature("combined") is None
    True
    """
    from leakdiag.bench.registry import make_detector, thesis_methods
    from leakdiag.detect.base import Alarm

    if name not in thesis_methods():
        return None
    spec = make_detector(name, "vca", Alarm()).spec()  # (the rig changes N, not these)
    return spec.method, tuple(spec.channels)


def resolve_method(method: str | None, channels: str | None, detector, meta,
                   detector_path: str | None) -> tuple[str | None, str | None]:
    """``--method`` and ``--channels`` as the monitor's feature options.

    A feature name passes unchanged. A ``fit -m`` name is the detector's own method when the
    file was fitted with it (or monitors its feature on its channels): then it is as if
    ``--method`` were left out. Without a detector it gives its feature and channels.

    Parameters
    ----------
    method : str or None
        From :class:`MonitorMethod`.
    channels : str or None
        ``--channels`` as given (``"p1,p2"``).
    detector : object or None
        The loaded detector file.
    meta : DetectorMeta or None
        Its metadata record.
    detector_path : str or None
        Its file (for the messages).

    Returns
    -------
    method : str or None
        Canonical feature name, or None for the detector's own.
    channels : str or None
        Channels, those of the fit name when ``--channels`` was not given.

    Raises
    ------
    click.UsageError
        A fit name that is not the detector's method, whose channels contradict the
        detector's or ``--channels``, or that names no single feature without a detector.
    """
    from leakdiag.features.registry import feature_names

    if method is None or method in feature_names():
        return method, channels
    feature = fit_method_feature(method)
    if detector is not None:
        own = detector.spec() if callable(getattr(detector, "spec", None)) else None
        if meta is not None and meta.method == method or feature is not None and \
                own is not None and (own.method, tuple(own.channels)) == feature:
            return None, channels
        mine = method if feature is None else f"{method}, the {feature[0]} of " \
            f"{','.join(feature[1])}"
        theirs = (meta.method if meta is not None else type(detector).__name__) + \
            ("" if own is None else f", {own.label}")
        raise click.UsageError(f"--method {mine}: {detector_path} holds a detector of another "
                               f"method or channels ({theirs}); leave --method out to monitor "
                               "its own, or fit a detector with the method you want "
                               "(leakdiag fit -m)")
    if feature is None:
        raise click.UsageError(f"--method {method} is a detector of leakdiag fit -m, not one "
                               "feature: give --detector FILE fitted with it, or a feature "
                               f"({', '.join(feature_names(True))})")
    given = None if channels is None else tuple(c.strip() for c in channels.split(","))
    if given is not None and given != feature[1]:
        raise click.UsageError(f"--method {method} is the {feature[0]} of "
                               f"{','.join(feature[1])}; --channels {channels} contradicts it: "
                               f"leave --channels out, or give --method {feature[0]}")
    return feature[0], ",".join(feature[1])
