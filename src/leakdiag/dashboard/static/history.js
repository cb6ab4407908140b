// leakdiag history page: chunk summaries of every run of one actuator, alarms marked.
"use strict";
const cfg = JSON.parse(document.getElementById("cfg").textContent);
document.getElementById("name").textContent = cfg.name;

function cell(tr, text) {
  const td = document.createElement("td");
  td.textContent = (text === null || text === undefined) ? "–" : String(text);
  tr.appendChild(td);
}

// one colour per feature (blue first; orange is the score's, red the alarms')
const PALETTE = ["#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
  "#17becf"];

function rgba(hex, a) {
  const n = parseInt(hex.slice(1), 16);
  return "rgba(" + (n >> 16) + "," + ((n >> 8) & 255) + "," + (n & 255) + "," + a + ")";
}

fetch(cfg.api).then((r) => r.json()).then((h) => {
  const s = h.summaries;
  const shapes = h.alarms.map((a) => ({type: "line", xref: "x", yref: "paper", x0: a.raised_at,
    x1: a.raised_at, y0: 0, y1: 1, line: {color: "#d62728", width: 2}}));
  const feats = h.features.length ? h.features : [null];
  const traces = [], scores = [];
  feats.forEach((f, k) => {
    const idx = s.feature.map((g, i) => (g === f ? i : -1)).filter((i) => i >= 0);
    const pick = (col) => idx.map((i) => s[col][i]);
    const x = pick("recorded_at"), colour = PALETTE[k % PALETTE.length];
    const label = feats.length > 1 ? f : "mean";
    traces.push({x: x, y: pick("value_max"), mode: "lines", line: {width: 0},
      showlegend: false, hoverinfo: "skip", legendgroup: String(k)});
    traces.push({x: x, y: pick("value_min"), mode: "lines", line: {width: 0}, fill: "tonexty",
      fillcolor: rgba(colour, 0.2), name: "min-max",
      showlegend: k === 0, legendgroup: String(k)});
    traces.push({x: x, y: pick("value_mean"), mode: "lines+markers", name: plotlyText(label),
      line: {color: colour}, legendgroup: String(k)});
    const sc = pick("score_max");
    if (sc.some((v) => v !== null) || feats.length === 1) {
      scores.push({x: x, y: sc, mode: "lines+markers", name: feats.length > 1 ? plotlyText(f) :
        "max score per point", line: {color: k === 0 ? "#ff7f0e" : colour}});
    }
  });
  let per = h.chunks_per_point > 1 ? "per block of up to " + h.chunks_per_point +
    " chunks (" + h.n_chunks + " chunks, UTC)" : "per chunk (UTC)";
  if (h.runs_joined) {  // more runs than points and line breaks: whole runs merged, joined
    per += "; " + h.n_runs + " runs drawn as one line" + (h.runs_per_point > 1 ?
      ", up to " + h.runs_per_point + " whole runs per point" : "");
  }
  Plotly.newPlot("summary-plot", traces,
    {title: {text: (feats.length > 1 ? feats.length + " features " : "feature ") + per},
     shapes: shapes, margin: {t: 40, r: 20, b: 40, l: 60}, xaxis: {type: "date"},
     legend: {orientation: "h", x: 0, y: 1.12}},
    {displaylogo: false});
  Plotly.newPlot("score-plot", scores,
    {title: {text: "largest detector score per point"}, shapes: shapes,
     margin: {t: 40, r: 20, b: 40, l: 60}, xaxis: {type: "date"}},
    {displaylogo: false});
  const table = document.getElementById("alarms");
  for (const a of h.alarms) {
    const tr = document.createElement("tr");
    cell(tr, a.raised_at);
    cell(tr, a.alarm_time_s === null ? null : fmtTime(a.alarm_time_s));
    cell(tr, a.onset_s === null ? null : (a.onset_censored ? "at or before " : "") +
         fmtTime(a.onset_s));
    cell(tr, a.leak_lpm === null ? null : fmtNum(a.leak_lpm, " L/min") + " [" +
         fmtNum(a.leak_lpm_low, "") + ", " + fmtNum(a.leak_lpm_high, "") + "]" +
         (a.leak_interval ? " (" + a.leak_interval + ")" : "") +
         (a.leak_extrapolated ? " (extrapolated: outside the calibrated range)" : ""));
    cell(tr, a.cleared_time_s === null ? null : fmtTime(a.cleared_time_s));
    cell(tr, a.source);
    table.appendChild(tr);
  }
  const runs = document.getElementById("runs");
  for (const r of h.runs) {
    const tr = document.createElement("tr");
    tr.className = "run " + r.status;
    cell(tr, r.started_at);
    cell(tr, r.command);
    cell(tr, r.feature);
    cell(tr, r.status);
    cell(tr, r.n_windows);
    cell(tr, r.source);
    cell(tr, r.error);
    runs.appendChild(tr);
  }
  if (h.n_runs > h.runs.length) {
    const tr = document.createElement("tr");
    cell(tr, "... " + (h.n_runs - h.runs.length) + " older run(s) not listed");
    runs.appendChild(tr);
  }
  document.body.dataset.loaded = "1";
});
