"""The monitor's summary counts alarm raisings and, as the store and the live page do, alarm
episodes (one CUSUM excursion raised and cleared several times is one episode)."""

import copy
import sqlite3
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main
from leakdiag.stream.episodes import AlarmEpisodes
from leakdiag.dashboard.live import ActuatorLive


def _run(args):
    with CliRunner().isolation() as (out, err, _):
        code = main(args)
        return code, out.getvalue().decode(), err.getvalue().decode()


@pytest.fixture(scope="module")
def low_threshold_detector(leak_case, tmp_path_factory):
    """The leak case's detector with its threshold at 7: a false alarm at 15.4 s that clears
    and is raised again at 17.9 s before its CUSUM excursion ends, then the leak's alarm."""
    from leakdiag.stream.detector_file import load_detector_file, save_detector

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        det, meta = load_detector_file(leak_case["detector_path"])
    det = copy.deepcopy(det)
    det.threshold_, det.threshold_basis_ = 7.0, None
    path = tmp_path_factory.mktemp("low") / "det7.joblib"
    save_detector(det, meta, path)
    return path


@pytest.mark.parametrize("chunk", [7, 65536])
def test_summary_counts_raisings_and_the_stores_episodes(leak_case, low_threshold_detector,
                                                         tmp_path, chunk):
    """Before, the summary said "3 alarm(s)" beside 2 alarm rows in the store."""
    db = tmp_path / "ev.db"
    code, out, err = _run(["monitor", str(leak_case["recording"]), "--detector",
                           str(low_threshold_detector), "--chunk", str(chunk), "--store",
                           str(db)])
    assert code == 0, err
    raised = [ln for ln in out.splitlines() if ln.startswith("ALARM ")]
    con = sqlite3.connect(db)
    rows = con.execute("select alarm_time_s, cleared_time_s from alarms order by id").fetchall()
    con.close()
    assert [float(ln.split("t=")[1].split()[0]) for ln in raised] == [15.399, 17.869, 33.829]
    assert [r[0] for r in rows] == [15.399, 33.829] and rows[1][1] is None
    assert "3 alarm raising(s) in 2 episode(s), 0 degenerate" in out


def _cusum(rng, n, burn_in):
    """S+ and S- of a CUSUM on a random mean-shifting series (NaN in the burn-in)."""
    z = rng.normal(0, 1, n) + np.repeat(rng.normal(0, 0.6, n // 50 + 1), 50)[:n]
    up, down = np.zeros(n), np.zeros(n)
    sp = sm = 0.0
    for i in range(n):
        sp, sm = max(0.0, sp + z[i] - 0.5), max(0.0, sm - z[i] - 0.5)
        up[i], down[i] = sp, sm
    up[:burn_in] = down[:burn_in] = np.nan
    return up, down


def _splits(rng, n):
    cuts = np.sort(rng.choice(np.arange(1, n), size=rng.integers(0, 30), replace=False))
    return np.split(np.arange(n), cuts)


@pytest.mark.parametrize("seed", range(40))
def test_episodes_equal_the_live_pages(seed):
    """AlarmEpisodes, given the chunks as the monitor sees them, counts the episodes that
    ActuatorLive (the page and the store) counts given other splits of the same windows."""
    rng = np.random.default_rng(seed)
    n = 600
    up, down = _cusum(rng, n, burn_in=int(rng.integers(0, 20)))
    if seed % 3 == 0:
        down = np.where(np.isnan(up), np.nan, 0.0)  # direction "up": S- stays 0
    s = np.fmax(up, down)
    thr = float(rng.uniform(2.0, 6.0))
    a = np.where(np.isnan(s), False, s >= thr)
    t = np.arange(n) * 0.19 + 0.199
    v = rng.normal(size=n)
    live = ActuatorLive("x", "f", SimpleNamespace(threshold_=thr), 0.199)
    for idx in _splits(rng, n):
        live.update(t[idx], v[idx], s[idx], a[idx], 0.0, (up[idx], down[idx]))
    ep = AlarmEpisodes(thr)
    on = False
    for idx in _splits(rng, n):  # as the monitor calls it: chunks with a raising, or open
        prev = np.concatenate(([on], a[idx][:-1]))
        raised = np.flatnonzero(a[idx] & ~prev)
        on = bool(a[idx][-1])
        if len(raised) or ep.open:
            ep.add(raised.tolist(), s[idx], (up[idx], down[idx]))
    assert ep.n == live.episode


def test_episodes_by_hand():
    """Raised by S+ at 1, again at 3 without S+ back at 0 (one episode), S+ at 0 at 4 and
    raised at 5 (a second), then by S- at 7 while S+ never returned to 0 (a third)."""
    up = np.array([1.0, 2.0, 1.5, 2.5, 0.0, 3.0, 1.0, 1.0])
    down = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0])
    s = np.fmax(up, down)
    ep = AlarmEpisodes(2.0)
    ep.add([1, 3], s[:4], (up[:4], down[:4]))
    assert (ep.n, ep.open) == (1, True)
    ep.add([1, 3], s[4:], (up[4:], down[4:]))  # windows 5 and 7, indices of the chunk
    assert ep.n == 3


def test_a_threshold_free_scorer_uses_its_scores():
    """No finite threshold_ and no branches: the score is both branches, raised at its own
    value (as ActuatorLive does)."""
    s = np.array([0.0, 1.0, 0.5, 1.0, 0.0, 1.0])
    ep = AlarmEpisodes(float("nan"))
    ep.add([1, 3, 5], s)
    assert ep.n == 2
