"""A small self-contained report builder: HTML5 with embedded figures, and a Markdown twin.

A :class:`Report` is a list of blocks (headings, paragraphs, bullet lists, tables from DataFrames,
matplotlib figures). :meth:`Report.to_html` renders one HTML5 file with every figure embedded as a
base64 PNG (no external file, no script); :meth:`Report.to_markdown` renders the same content as
Markdown with the figures as PNG files beside it. :func:`check_html` verifies that a page is well
formed (every non-void element closed in order, one ``html``/``head``/``body``/``title``).
"""

from __future__ import annotations

import base64
import html
import io
import math
import re
from dataclasses import dataclass
from html.parser import HTMLParser
from pathlib import Path
from typing import Any, Sequence

__all__ = ["Report", "check_html", "format_value"]

#: Narrowest PNG a report figure is written at (pixels): narrower ones are rendered at a higher dpi.
MIN_FIGURE_WIDTH_PX = 900

#: HTML5 void elements (no closing tag).
_VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source",
         "track", "wbr"}

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:72rem;margin:2rem auto;
padding:0 1rem;color:#1b1b1b;line-height:1.45}
h1,h2,h3,h4{line-height:1.2}h2{border-bottom:1px solid #ccc;padding-bottom:.2rem;margin-top:2.2rem}
table{border-collapse:collapse;margin:.6rem 0 1.2rem;font-size:.88rem}
th,td{border:1px solid #bbb;padding:.2rem .5rem;text-align:right}th{background:#eee}
td.t,th.t{text-align:left}caption{caption-side:top;text-align:left;font-weight:600;padding:.3rem 0}
figure{margin:1rem 0}figure img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:.9rem;color:#444}code{background:#f4f4f4;padding:0 .2rem}
.agree{color:#0a6b0a}.disagree{color:#a30000}
nav ul{columns:2}
""".strip()


def format_value(value: Any, digits: int = 5) -> str:
    """Render one table cell as text.

    Parameters
    ----------
    value : object
        Cell value.
    digits : int, default 5
        Significant digits for floats.

    Returns
    -------
    str
        ``""`` for None/NaN, ``"true"``/``"false"`` for booleans, floats with ``digits``
        significant digits, everything else ``str(value)``.

    Examples
    --------
    >>> format_value(42.52218), format_value(float("nan")), format_value(True)
    ('42.522', '', 'true')
    """
    import numpy as np

    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):
        if not np.isfinite(value):
            return "" if np.isnan(value) else str(float(value))
        return f"{float(value):.{digits}g}"
    try:
        import pandas as pd

        if value is pd.NA or (not isinstance(value, str) and pd.isna(value)):
            return ""
    except (TypeError, ValueError):
        pass
    return str(value)


def _slug(text: str) -> str:
    s = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")
    return s or "section"


@dataclass(frozen=True)
class _Block:
    kind: str
    data: Any


class Report:
    """Builder of a self-contained HTML report and its Markdown twin.

    Parameters
    ----------
    title : str
        Page title (also the first heading).

    Examples
    --------
    >>> import pandas as pd
    >>> r = Report("Demo")
    >>> r.heading("Results")
    'results'
    >>> r.paragraph("Feature falls after the leak: 1 < 2.")
    >>> r.table(pd.DataFrame({"lag": [1, 2], "pct_change": [42.52218, 43.4]}), "Table 1")
    >>> page = r.to_html()
    >>> check_html(page)
    >>> "1 &lt; 2" in page, "<td>42.522</td>" in page
    (True, True)
    >>> print(r.to_markdown().splitlines()[8])
    | lag | pct_change |
    """

    def __init__(self, title: str) -> None:
        self.title = str(title)
        self._blocks: list[_Block] = []
        self._anchors: set[str] = set()
        self._n_fig = 0

    # ------------------------------------------------------------------ building
    def heading(self, text: str, level: int = 2) -> str:
        """Add a heading (level 2-4); return its anchor id (unique in the page).

        Parameters
        ----------
        text : str
            Heading text.
        level : int, default 2
            2 for a section, 3-4 for sub-sections.

        Returns
        -------
        str
            The anchor (``id``) of the heading.

        Raises
        ------
        ValueError
            If level is not 2, 3 or 4.
        """
        if level not in (2, 3, 4):
            raise ValueError(f"level={level!r} must be 2, 3 or 4 (1 is the page title)")
        anchor = base = _slug(text)
        i = 2
        while anchor in self._anchors:
            anchor, i = f"{base}-{i}", i + 1
        self._anchors.add(anchor)
        self._blocks.append(_Block("heading", (str(text), level, anchor)))
        return anchor

    def paragraph(self, text: str) -> None:
        """Add a paragraph of plain text (escaped; ``code`` in backticks is kept as code).

        Parameters
        ----------
        text : str
            Paragraph text.
        """
        self._blocks.append(_Block("para", str(text)))

    def bullets(self, items: Sequence[str]) -> None:
        """Add a bullet list of plain-text items.

        Parameters
        ----------
        items : sequence of str
            List items.
        """
        self._blocks.append(_Block("list", [str(i) for i in items]))

    def table(self, df, caption: str | None = None, digits: int = 5) -> None:
        """Add a table from a DataFrame (index left out; reset it first to keep it).

        Parameters
        ----------
        df : pandas.DataFrame
            Table content.
        caption : str, optional
            Caption shown above the table.
        digits : int, default 5
            Significant digits for floats.
        """
        cols = [str(c) for c in df.columns]
        text_cols = [not _is_numeric(df[c]) for c in df.columns]
        rows = [[format_value(v, digits) for v in row] for row in df.itertuples(index=False)]
        self._blocks.append(_Block("table", (caption, cols, text_cols, rows)))

    def figure(self, fig, caption: str, dpi: int = 150, name: str | None = None) -> str:
        """Add a matplotlib figure (rendered to PNG now, then closed); return its file name.

        Parameters
        ----------
        fig : matplotlib.figure.Figure
            The figure.
        caption : str
            Caption.
        dpi : int, default 150
            Resolution of the PNG; raised when the (tightly cropped) PNG would be narrower than
            :data:`MIN_FIGURE_WIDTH_PX`, so that text stays readable.
        name : str, optional
            File name stem, e.g. ``"table-5-3-series"`` (made unique with a number if taken);
            default ``fig-NNN``.

        Returns
        -------
        str
            File name used for the Markdown twin, e.g. ``"table-5-3-series.png"`` or
            ``"fig-003.png"``.
        """
        import matplotlib.pyplot as plt

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
        width = int.from_bytes(buf.getvalue()[16:20], "big")  # PNG IHDR: width in pixels
        if width < MIN_FIGURE_WIDTH_PX:  # the tight box trimmed it: render finer, not smaller
            buf = io.BytesIO()
            fig.savefig(buf, format="png", dpi=math.ceil(dpi * MIN_FIGURE_WIDTH_PX / width),
                        bbox_inches="tight")
        plt.close(fig)
        self._n_fig += 1
        stem = re.sub(r"[^A-Za-z0-9_.-]+", "-", name).strip("-.") if name else ""
        name = f"{stem}.png" if stem else f"fig-{self._n_fig:03d}.png"
        if name in self.figures:
            name = f"{stem}-{self._n_fig:03d}.png"
        self._blocks.append(_Block("figure", (name, buf.getvalue(), str(caption))))
        return name

    # ------------------------------------------------------------------ rendering
    @property
    def figures(self) -> dict[str, bytes]:
        """File name -> PNG bytes of every figure."""
        return {b.data[0]: b.data[1] for b in self._blocks if b.kind == "figure"}

    def to_html(self) -> str:
        """Render the page as one self-contained HTML5 document.

        Returns
        -------
        str
            The HTML text (figures embedded as ``data:image/png;base64`` URIs).
        """
        esc = html.escape
        out = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8" />',
               '<meta name="viewport" content="width=device-width, initial-scale=1" />',
               f"<title>{esc(self.title)}</title>", f"<style>{_CSS}</style>", "</head>",
               "<body>", f"<h1>{esc(self.title)}</h1>"]
        toc = [b.data for b in self._blocks if b.kind == "heading" and b.data[1] == 2]
        if len(toc) > 2:
            out.append("<nav><ul>")
            out += [f'<li><a href="#{a}">{esc(t)}</a></li>' for t, _, a in toc]
            out.append("</ul></nav>")
        for b in self._blocks:
            if b.kind == "heading":
                text, level, anchor = b.data
                out.append(f'<h{level} id="{anchor}">{esc(text)}</h{level}>')
            elif b.kind == "para":
                out.append(f"<p>{_inline_html(b.data)}</p>")
            elif b.kind == "list":
                out.append("<ul>" + "".join(f"<li>{_inline_html(i)}</li>" for i in b.data)
                           + "</ul>")
            elif b.kind == "table":
                caption, cols, text_cols, rows = b.data
                out.append("<table>")
                if caption:
                    out.append(f"<caption>{esc(caption)}</caption>")
                cls = [' class="t"' if t else "" for t in text_cols]
                out.append("<thead><tr>" + "".join(
                    f"<th{k}>{esc(c)}</th>" for c, k in zip(cols, cls)) + "</tr></thead><tbody>")
                for row in rows:
                    out.append("<tr>" + "".join(
                        f"<td{k}>{esc(v)}</td>" for v, k in zip(row, cls)) + "</tr>")
                out.append("</tbody></table>")
            elif b.kind == "figure":
                name, png, caption = b.data
                data = base64.b64encode(png).decode("ascii")
                out.append(f'<figure><img src="data:image/png;base64,{data}" '
                           f'alt="{esc(caption)}" /><figcaption>{esc(caption)}</figcaption>'
                           "</figure>")
        out += ["</body>", "</html>", ""]
        return "\n".join(out)

    def to_markdown(self, figure_dir: str = "figures") -> str:
        """Render the same content as Markdown (figures referenced as ``figure_dir/NAME``).

        Parameters
        ----------
        figure_dir : str, default "figures"
            Folder of the PNG files relative to the Markdown file.

        Returns
        -------
        str
            Markdown text.
        """
        out = [f"# {self.title}", ""]
        for b in self._blocks:
            if b.kind == "heading":
                text, level, _ = b.data
                out += ["#" * level + " " + text, ""]
            elif b.kind == "para":
                out += [b.data, ""]
            elif b.kind == "list":
                out += [f"- {i}" for i in b.data] + [""]
            elif b.kind == "table":
                caption, cols, _, rows = b.data
                if caption:
                    out += [f"**{caption}**", ""]
                out.append("| " + " | ".join(_md_cell(c) for c in cols) + " |")
                out.append("|" + "|".join("---" for _ in cols) + "|")
                out += ["| " + " | ".join(_md_cell(v) for v in row) + " |" for row in rows]
                out.append("")
            elif b.kind == "figure":
                name, _, caption = b.data
                out += [f"![{caption}]({figure_dir}/{name})", "", f"*{caption}*", ""]
        return "\n".join(out)

    def write(self, out_dir, html_name: str = "index.html", md_name: str = "report.md",
              figure_dir: str = "figures") -> dict[str, Path]:
        """Write the HTML page, the Markdown twin and its PNG figures into ``out_dir``.

        Parameters
        ----------
        out_dir : path-like
            Output folder (created).
        html_name, md_name : str
            File names of the page and of the Markdown twin.
        figure_dir : str, default "figures"
            Sub-folder of the PNG files for the Markdown twin.

        Returns
        -------
        dict
            ``{"html": path, "markdown": path, "figures": folder}``.

        Raises
        ------
        OSError
            Before any file is written, naming the path: the page or the Markdown twin is a
            folder, or the figure folder exists and is not a folder.
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        for name in (html_name, md_name):
            if (out / name).is_dir():
                raise OSError(f"{out / name} exists and is a folder, not a file")
        if self.figures and (out / figure_dir).exists() and not (out / figure_dir).is_dir():
            raise OSError(f"{out / figure_dir} exists and is not a folder")
        page = self.to_html()
        check_html(page)
        (out / html_name).write_text(page, encoding="utf-8")
        (out / md_name).write_text(self.to_markdown(figure_dir), encoding="utf-8")
        fig_dir = out / figure_dir
        if self.figures:
            fig_dir.mkdir(exist_ok=True)
            for name, png in self.figures.items():
                (fig_dir / name).write_bytes(png)
        return {"html": out / html_name, "markdown": out / md_name, "figures": fig_dir}


def _is_numeric(series) -> bool:
    import pandas as pd

    return bool(pd.api.types.is_numeric_dtype(series)) and not pd.api.types.is_bool_dtype(series)


def _inline_html(text: str) -> str:
    parts = str(text).split("`")
    return "".join(html.escape(p) if i % 2 == 0 else f"<code>{html.escape(p)}</code>"
                   for i, p in enumerate(parts))


def _md_cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


class _Checker(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[tuple[str, tuple[int, int]]] = []
        self.errors: list[str] = []
        self.counts: dict[str, int] = {}

    def handle_starttag(self, tag, attrs):
        self.counts[tag] = self.counts.get(tag, 0) + 1
        if tag not in _VOID:
            self.stack.append((tag, self.getpos()))

    def handle_startendtag(self, tag, attrs):
        self.counts[tag] = self.counts.get(tag, 0) + 1
        if tag not in _VOID:
            self.errors.append(f"<{tag} /> self-closed at line {self.getpos()[0]}")

    def handle_endtag(self, tag):
        if tag in _VOID:
            self.errors.append(f"end tag </{tag}> of a void element at line {self.getpos()[0]}")
            return
        if not self.stack or self.stack[-1][0] != tag:
            top = self.stack[-1] if self.stack else ("nothing", (0, 0))
            self.errors.append(
                f"</{tag}> at line {self.getpos()[0]} closes <{top[0]}> opened at line {top[1][0]}")
            return
        self.stack.pop()


def check_html(text: str) -> None:
    """Check that an HTML5 page is well formed.

    Parameters
    ----------
    text : str
        The page.

    Raises
    ------
    ValueError
        Naming the first problem: missing ``<!DOCTYPE html>``, an element closed out of order
        or never closed, or not exactly one ``html``, ``head``, ``body`` and ``title``.

    Examples
    --------
    >>> check_html("<!DOCTYPE html><html><head><title>t</title></head><body><p>x</p></body></html>")
    >>> check_html("<!DOCTYPE html><html><head><title>t</title></head><body><p>x</body></html>")
    Traceback (most recent call last):
    ...
    ValueError: HTML not well formed: </body> at line 1 closes <p> opened at line 1
    """
    if not text.lstrip().lower().startswith("<!doctype html>"):
        raise ValueError("HTML not well formed: it must start with <!DOCTYPE html>")
    chk = _Checker()
    chk.feed(text)
    chk.close()
    if chk.errors:
        raise ValueError(f"HTML not well formed: {chk.errors[0]}")
    if chk.stack:
        tag, pos = chk.stack[-1]
        raise ValueError(f"HTML not well formed: <{tag}> opened at line {pos[0]} is never closed")
    for tag in ("html", "head", "body", "title"):
        if chk.counts.get(tag, 0) != 1:
            raise ValueError(
                f"HTML not well formed: expected one <{tag}>, found {chk.counts.get(tag, 0)}")
