"""The command line's feature options, read from the feature registry (defined once).

``--method`` accepts every registered feature (any spelling the registry knows, checked when
the command line is parsed, so a feature registered after import is offered too);
:func:`check_setting_options` refuses ``--lag``/``--lag-ratio`` where no chosen feature takes
them; :func:`spec_from_options` builds the :class:`~leakdiag.features.MethodSpec` of one feature
from the options. ``leakdiag analyze``, ``sweep`` and ``monitor`` all use them.
"""

from __future__ import annotations

import click

from leakdiag.features.registry import feature_names, feature_record, normalize_method
from leakdiag.features.spec import MethodSpec

__all__ = ["FeatureChoice", "check_setting_options", "spec_from_options"]


class FeatureChoice(click.ParamType):
    """A registered feature's canonical name (aliases accepted), checked at parse time.

    Parameters
    ----------
    streamable : bool, optional
        Offer only streamable (True) features.
    single : bool, optional
        Offer only single-valued (True) features.
    extra : tuple of str, default ()
        Other accepted words (e.g. ``"all"``), returned as given.
    """

    name = "feature"

    def __init__(self, streamable: bool | None = None, single: bool | None = None,
                 extra: tuple[str, ...] = ()):
        self.streamable = streamable
        self.single = single
        self.extra = tuple(extra)

    def choices(self) -> tuple[str, ...]:
        """The accepted canonical names and extra words, now.

        Returns
        -------
        tuple of str
        """
        return feature_names(self.streamable, self.single) + self.extra

    def get_metavar(self, param, ctx=None) -> str:  # click >= 8.2 passes ctx
        """``[name|name|...]`` for the usage line.

        Returns
        -------
        str
        """
        return "[" + "|".join(self.choices()) + "]"

    def convert(self, value, param, ctx):
        """The canonical name of ``value`` (fails with the list of choices).

        Returns
        -------
        str
        """
        if value in self.extra:
            return value
        try:
            name = normalize_method(value)
        except ValueError:
            name = None
        if name is None or name not in self.choices():
            self.fail(f"{value!r} is not one of {', '.join(map(repr, self.choices()))}",
                      param, ctx)
        return name


def _takers(kind: str) -> list[str]:
    return [n for n in feature_names() if feature_record(n).setting == kind]


def check_setting_options(methods, lag, lag_ratio) -> None:
    """Refuse ``--lag``/``--lag-ratio`` when no chosen feature takes it (never ignored silently).

    Parameters
    ----------
    methods : sequence of str
        Canonical names of the chosen features.
    lag, lag_ratio : object or None
        The options as given (None when not given).

    Raises
    ------
    click.UsageError
        Naming the features that take the option.
    """
    kinds = {feature_record(m).setting for m in methods}
    if lag is not None and "lag" not in kinds:
        ratio = _takers("lag_ratio")
        hint = f"; {' and '.join(ratio)} {'takes' if len(ratio) == 1 else 'take'} --lag-ratio" \
            if ratio else ""
        raise click.UsageError(f"--lag applies to {' and '.join(_takers('lag'))} only{hint}")
    if lag_ratio is not None and "lag_ratio" not in kinds:
        raise click.UsageError(
            f"--lag-ratio applies to --method {' and '.join(_takers('lag_ratio'))} only")


def spec_from_options(method: str, channels, lag, lag_ratio, window: int, overlap: float
                      ) -> MethodSpec:
    """The spec of one feature from command-line options (the feature's default setting when
    its option is not given; an option of the other kind is left out).

    Parameters
    ----------
    method : str
        Feature name.
    channels : str or None
        ``"p1,p2"`` or None for the feature's default channels.
    lag, lag_ratio : object or None
        Options as given.
    window : int
        Window in samples.
    overlap : float
        Overlap in percent.

    Returns
    -------
    MethodSpec
    """
    rec = feature_record(method)
    kw = {}
    if rec.setting == "lag":
        kw["lag"] = lag
    elif rec.setting == "lag_ratio":
        kw["lag_ratio"] = lag_ratio
    return MethodSpec(rec.name, channels or (), window=window, overlap=overlap, **kw)
