// leakdiag pages: how numbers and labels are written (loaded before live.js and history.js;
// tests/dashboard/test_format_js.py runs these functions in node).
"use strict";

// Decimals of a stream time in seconds: millisecond resolution at any magnitude (6 significant
// digits wrote 100059.899 s as "100060 s", and a day into a stream lost the seconds' digits).
const TIME_DECIMALS = 3;

function fmtTime(v, unit) {
  // A time in s with TIME_DECIMALS fixed decimals; "–" for none.
  if (v === null || v === undefined || !Number.isFinite(Number(v))) return "–";
  return Number(v).toFixed(TIME_DECIMALS) + (unit === undefined ? " s" : unit);
}

function fmtNum(v, unit) {
  // A number with 6 significant digits, trailing zeros of its fraction dropped (never those of
  // its whole part: 100000 stays 100000, it was shown as "1"); "–" for none.
  if (v === null || v === undefined) return "–";
  const x = Number(v);
  if (!Number.isFinite(x)) return String(x) + unit;
  const s = x.toPrecision(6).replace(/\.(\d*?)0+(e|$)/, (m, d, e) => (d ? "." + d : "") + e);
  return s + unit;
}

function plotlyText(s) {
  // A label as text for Plotly, which renders <a>, <span style>, <b>, <br> ... in names and
  // titles: &, < and > as entities, which Plotly shows as the characters.
  if (s === null || s === undefined) return s;
  return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;");
}
