"""A real headless Chromium on the live page during a replay, and on the fleet/history pages.

Skipped, with the reason printed once at the end of the run, when Debian's chromium and
chromium-driver (or selenium) are missing. Servers bind 127.0.0.1 on a free port and stop.
"""

import io
import re
import select
import signal
import subprocess
import sys
import time

import numpy as np

from .conftest import src_env

LEAKDIAG = [sys.executable, "-c", "import sys; from leakdiag.cli.main import main; "
            "sys.exit(main())"]
FEATURE_RGB, SCORE_RGB = (31, 119, 180), (255, 127, 14)  # trace colours of live.js/history.js


def _url_from(p, prefix, stream, timeout_s=90.0):
    """Read the child's ``stream`` until a line with ``prefix``; return the URL on it."""
    t_end = time.monotonic() + timeout_s
    seen = []
    while time.monotonic() < t_end:
        r, _, _ = select.select([stream], [], [], 0.5)
        if r:
            line = stream.readline()
            if not line:
                break
            seen.append(line)
            m = re.search(r"(http://127\.0\.0\.1:\d+/\S*)", line)
            if line.startswith(prefix) and m:
                return m.group(1)
    p.kill()
    p.wait()
    raise AssertionError(f"no {prefix!r} line from the child: {''.join(seen)}{p.stderr.read()}")


def _stop(p):
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)  # a clean stop (SIGINT may be ignored in background jobs)
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
    p.stderr.close()
    if p.stdout:
        p.stdout.close()


def _pixels(png: bytes, rgb, tol=40) -> int:
    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)
    return int((np.abs(a - np.array(rgb)).sum(axis=2) < tol).sum())


def _fmt(v):
    return f"{v:.3f} s"  # the live page's times: ms resolution (format.js, fmtTime)


def test_live_page_turns_to_alarm_at_the_right_time(browser, leak_case, tmp_path):
    v = leak_case["verdict"]
    db = tmp_path / "ev.db"
    p = subprocess.Popen(LEAKDIAG + ["monitor", "-i", str(leak_case["recording"]), "--detector",
                                     str(leak_case["detector_path"]), "--chunk", "100",
                                     "--replay", "4x", "--dashboard", "127.0.0.1:0",
                                     "--store", str(db), "--linger", "120"],
                         env=src_env(), stderr=subprocess.PIPE, stdout=subprocess.PIPE,
                         text=True)
    try:
        url = _url_from(p, "dashboard:", p.stdout)
        assert re.fullmatch(r"http://127\.0\.0\.1:\d+/live/rig7", url)
        browser.get(url)
        states = []
        t_end = time.monotonic() + 120
        while time.monotonic() < t_end:
            st = browser.find_element("id", "state").text
            if not states or states[-1] != st:
                states.append(st)
            if st == "ALARM":
                break
            time.sleep(0.05)
        assert "OK" in states and states[-1] == "ALARM", states  # seen OK, then ALARM
        assert browser.find_element("id", "alarm-time").text == _fmt(v.alarm_time_s)
        assert browser.find_element("id", "onset").text == _fmt(v.onset_s)
        assert "L/min [" in browser.find_element("id", "leak").text
        # read in one script: the page re-renders the list with every snapshot (a WebElement
        # taken first can go stale before its text is read)
        first_event = browser.execute_script(
            "const l = document.querySelectorAll('#events li');"
            "return l.length ? l[l.length - 1].innerText : '';")
        assert first_event.startswith(f"ALARM at t={_fmt(v.alarm_time_s)}")
        t_end = time.monotonic() + 120  # replay to the end: the final estimate equals predict
        while "input ended" not in browser.find_element("id", "last-time").text:
            assert time.monotonic() < t_end
            time.sleep(0.2)
        leak = browser.find_element("id", "leak").text
        assert leak.startswith(f"{v.leak_lpm:.6g}".rstrip("0").rstrip(".") + " L/min")
        png = browser.get_screenshot_as_png()
        (tmp_path / "live.png").write_bytes(png)
        assert _pixels(png, FEATURE_RGB) > 2000, "feature trace not drawn"
        assert _pixels(png, SCORE_RGB) > 1000, "score trace not drawn"
        # the threshold line drawn across the score plot, at the detector's threshold
        thr = browser.execute_script(
            "return document.getElementById('score-plot').data"
            ".filter((t) => t.name === 'threshold').map((t) => t.y);")
        assert thr == [[leak_case["detector"].threshold_] * 2]
        assert _pixels(png, (0, 0, 0), tol=10) > 300, "threshold line not drawn"
        # updates reach the page within 1 s of the chunk's arrival (issue 17; the benchmark
        # measures it in real time): every render during the replay, after the page's start-up.
        # A fast replay updates the page at REPLAY_HZ (2 Hz), so the 15-s replay renders at most
        # about 30 times, fewer when the page opens late; a full test run beside other work gave
        # 23 (session 28), which "more than 20" after the first 3 had failed on
        lat = np.array(browser.execute_script("return window.leakdiagLatencies;")[3:])
        assert len(lat) >= 10 and np.median(lat) <= 1.0, (len(lat),
                                                          np.percentile(lat, [50, 95, 100]))
    finally:
        _stop(p)
    assert p.returncode == 0


def test_fleet_page_lists_actuators_and_history(browser, leak_case, tmp_path):
    from leakdiag.store import AlarmRecord, ChunkSummary, EventStore

    db = tmp_path / "ev.db"
    st = EventStore(db)
    for name, alarm in (("rig1", False), ("rig2", True)):
        run = st.start_run(name, command="monitor", source=f"{name}.parquet", feature="ac p1",
                           threshold=20.0)
        for i in range(20):
            al = [AlarmRecord(i + 0.5, 25.0, 20.0, onset_s=i - 2.0, leak_lpm=0.2,
                              leak_lpm_low=0.1, leak_lpm_high=0.3)] if alarm and i == 15 else []
            st.add_chunk(run, ChunkSummary(i, i + 0.9, 5, 0, 0.5 - 0.02 * i * alarm, 0.1, 0.9,
                                           0.4, 2.0 * i * alarm, 1.0, alarm and i >= 15), al)
        st.end_run(run)
    st.close()
    p = subprocess.Popen(LEAKDIAG + ["dashboard", "--store", str(db), "--bind", "127.0.0.1:0"],
                         env=src_env(), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                         text=True)
    try:
        url = _url_from(p, "leakdiag dashboard:", p.stderr)
        browser.get(url)
        rows = browser.find_elements("css selector", "#fleet tr[data-actuator]")
        cells = [[c.text for c in r.find_elements("tag name", "td")] for r in rows]
        assert [c[0] for c in cells] == ["rig1", "rig2"]
        # the state, and under it the run that gave it (store audit 2026-11-27, finding 8)
        assert [c[1].splitlines() for c in cells] == [["OK", "monitor finished, 100 windows"],
                                                      ["ALARM", "monitor finished, 100 windows"]]
        assert cells[1][4] == "0.2 L/min [0.1, 0.3]" and "t=15.5 s" in cells[1][2]
        rows[1].find_element("tag name", "a").click()
        t_end = time.monotonic() + 60
        while browser.find_element("tag name", "body").get_attribute("data-loaded") != "1":
            assert time.monotonic() < t_end, "history page did not load its data"
            time.sleep(0.1)
        assert browser.current_url.endswith("/history/rig2")
        alarm_rows = browser.find_elements("css selector", "#alarms tr")[1:]
        assert len(alarm_rows) == 1 and "15.500 s" in alarm_rows[0].text  # times to the ms
        # the alarm marked on both plots, at the time it was raised; 20 chunks drawn
        marks = browser.execute_script(
            "return ['summary-plot', 'score-plot'].map((id) => {"
            "const p = document.getElementById(id);"
            "return [p.layout.shapes.map((s) => s.x0), p.data[p.data.length - 1].y.length];});")
        al = EventStore(db).history("rig2")[1]
        raised = al.loc[0, "raised_at"].isoformat()
        assert marks == [[[raised], 20], [[raised], 20]]
        png = browser.get_screenshot_as_png()
        assert _pixels(png, FEATURE_RGB) > 500 and _pixels(png, SCORE_RGB) > 500
    finally:
        _stop(p)
    assert p.returncode == 0
