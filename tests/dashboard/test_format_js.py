"""The pages' number and label formatting (static/format.js), run in node.

An audit (session 26) found the live page's ``fmt`` stripping the zeros of whole numbers:
``toPrecision(6).replace(/\\.?0+$/, "")`` wrote 100000 as "1" and 100059.899 s as "10006 s".
Skipped when node is missing (the browser tests load the same file on the pages).
"""

import json
import shutil
import subprocess
from pathlib import Path

import pytest

FORMAT_JS = Path(__file__).parents[2] / "src" / "leakdiag" / "dashboard" / "static" / \
    "format.js"
NODE = shutil.which("node") or shutil.which("nodejs")

# runs format.js in a fresh context and applies its functions to the JSON calls on stdin
RUNNER = r"""
const fs = require("fs"), vm = require("vm");
const ctx = {};
vm.createContext(ctx);
vm.runInContext(fs.readFileSync(process.argv[1], "utf8"), ctx);
const calls = JSON.parse(fs.readFileSync(0, "utf8"));
process.stdout.write(JSON.stringify(calls.map(([f, ...args]) => ctx[f](...args))));
"""


def _run(calls):
    if NODE is None:
        pytest.skip("no node on this machine (the browser tests load format.js on the pages)")
    out = subprocess.run([NODE, "-e", RUNNER, str(FORMAT_JS)], input=json.dumps(calls),
                         capture_output=True, text=True, timeout=60, check=True)
    return json.loads(out.stdout)


def test_whole_numbers_keep_their_zeros():
    got = _run([["fmtNum", 100000, ""], ["fmtNum", 120, " L/min"], ["fmtNum", 2.0, ""],
                ["fmtNum", 1.5, " L/min"], ["fmtNum", 1.05, ""], ["fmtNum", 0.000123, ""],
                ["fmtNum", -0.25, ""], ["fmtNum", 1.5e9, ""], ["fmtNum", 0.123456789, ""],
                ["fmtNum", None, " s"]])
    assert got == ["100000", "120 L/min", "2", "1.5 L/min", "1.05", "0.000123", "-0.25",
                   "1.5e+9", "0.123457", "–"]


def test_times_keep_milliseconds_at_any_magnitude():
    got = _run([["fmtTime", 100059.899], ["fmtTime", 100000], ["fmtTime", 57.859500000000004],
                ["fmtTime", 0.5], ["fmtTime", 86400.001, ""], ["fmtTime", None]])
    assert got == ["100059.899 s", "100000.000 s", "57.860 s", "0.500 s", "86400.001", "–"]


def test_labels_reach_plotly_as_text():
    """Plotly renders a subset of HTML in trace names and titles; escaped, it shows the
    characters."""
    got = _run([["plotlyText", '<a href="http://x">f</a>'], ["plotlyText", "a & b"],
                ["plotlyText", "acf p1 1 N=200 5%"]])
    assert got == ['&lt;a href="http://x"&gt;f&lt;/a&gt;', "a &amp; b", "acf p1 1 N=200 5%"]
