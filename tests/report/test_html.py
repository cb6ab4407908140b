"""Tests of the HTML/Markdown report builder."""

import base64

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from leakdiag.report.html import Report, check_html, format_value  # noqa: E402


def make_report():
    r = Report("Leak <report> & co")
    r.heading("Case study 1")
    r.paragraph("Autocorrelation falls: `rms_change` says -42 %.")
    r.bullets(["a < b", "c"])
    r.table(pd.DataFrame({"setting": ["lag 1", "lag 2"], "pct_change": [42.52218, 43.40],
                          "agrees": [True, False]}), caption="Table 5-1")
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    name = r.figure(fig, "A falling line")
    r.heading("Case study 1")
    return r, name


def test_html_well_formed_and_self_contained(tmp_path):
    r, name = make_report()
    page = r.to_html()
    check_html(page)
    assert "<title>Leak &lt;report&gt; &amp; co</title>" in page
    assert "<code>rms_change</code>" in page
    assert page.count('<img src="data:image/png;base64,') == 1
    b64 = page.split("base64,")[1].split('"')[0]
    assert base64.b64decode(b64)[:8] == b"\x89PNG\r\n\x1a\n"
    assert 'id="case-study-1"' in page and 'id="case-study-1-2"' in page
    assert '<td class="t">lag 1</td><td>42.522</td><td class="t">true</td>' in page
    assert "src=\"http" not in page and "<script" not in page
    paths = r.write(tmp_path)
    assert (tmp_path / "figures" / name).read_bytes()[:4] == b"\x89PNG"
    md = paths["markdown"].read_text()
    assert "| setting | pct_change | agrees |" in md
    assert "| lag 2 | 43.4 | false |" in md
    assert f"![A falling line](figures/{name})" in md


@pytest.mark.parametrize("page, msg", [
    ("<html><head><title>t</title></head><body></body></html>", "DOCTYPE"),
    ("<!DOCTYPE html><html><head><title>t</title></head><body><div></body></html>",
     "closes <div>"),
    ("<!DOCTYPE html><html><head><title>t</title></head><body><p>", "never closed"),
    ("<!DOCTYPE html><html><head></head><body></body></html>", "one <title>, found 0"),
    ("<!DOCTYPE html><html><head><title>t</title></head><body><br></br></body></html>",
     "void element"),
])
def test_check_html_rejects(page, msg):
    with pytest.raises(ValueError, match=msg):
        check_html(page)


def test_format_value():
    assert format_value(137.88154) == "137.88"
    assert format_value(None) == ""
    assert format_value(pd.NA) == ""
    assert format_value(3) == "3"


def test_heading_level():
    with pytest.raises(ValueError, match="level=1 must be 2, 3 or 4"):
        Report("x").heading("y", level=1)


def test_figures_are_readable_and_named_on_request(tmp_path):
    """Issue 15: report figures >= 900 px wide (150 dpi), named after their table when asked."""
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    r = Report("t")
    names = []
    for _ in range(2):
        fig, ax = plt.subplots(figsize=(6.4, 3.8))
        ax.plot([0, 1], [0, 1])
        names.append(r.figure(fig, "a line", name="table 5-3 series"))
    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    ax.plot([0, 1], [1, 0])
    names.append(r.figure(fig, "unnamed"))
    assert names == ["table-5-3-series.png", "table-5-3-series-002.png", "fig-003.png"]
    r.write(tmp_path)
    assert all(mpimg.imread(tmp_path / "figures" / n).shape[1] >= 900 for n in names)
