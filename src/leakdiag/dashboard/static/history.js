// leakdiag history page: chunk summaries of every run of one actuator, alarms marked.
"use strict";
const cfg = JSON.parse(document.getElementById("cfg").textContent);
document.getElementById("name").textContent = cfg.name;

function cell(tr, text) {
  const td = document.createElement("td");
  td.textContent = (text === null || text === undefined) ? "–" : String(text);
  tr.appendChild(td);
}

fetch(cfg.api).then((r) => r.json()).then((h) => {
  const s = h.summaries;
  const shapes = h.alarms.map((a) => ({type: "line", xref: "x", yref: "paper", x0: a.raised_at,
    x1: a.raised_at, y0: 0, y1: 1, line: {color: "#d62728", width: 2}}));
  Plotly.newPlot("summary-plot", [
    {x: s.recorded_at, y: s.value_max, mode: "lines", line: {width: 0}, showlegend: false,
     hoverinfo: "skip"},
    {x: s.recorded_at, y: s.value_min, mode: "lines", line: {width: 0}, fill: "tonexty",
     fillcolor: "rgba(31,119,180,0.2)", name: "min-max"},
    {x: s.recorded_at, y: s.value_mean, mode: "lines+markers", name: "mean",
     line: {color: "#1f77b4"}}],
    {title: {text: h.chunks_per_point > 1 ? "feature per block of up to " + h.chunks_per_point +
       " chunks (" + h.n_chunks + " chunks, UTC)" : "feature per chunk (UTC)"},
     shapes: shapes, margin: {t: 40, r: 20, b: 40, l: 60},
     legend: {orientation: "h", x: 0, y: 1.12}},
    {displaylogo: false});
  Plotly.newPlot("score-plot", [{x: s.recorded_at, y: s.score_max, mode: "lines+markers",
    name: "max score per point", line: {color: "#ff7f0e"}}],
    {title: {text: "largest detector score per point"}, shapes: shapes, margin: {t: 40, r: 20, b: 40, l: 60}},
    {displaylogo: false});
  const table = document.getElementById("alarms");
  for (const a of h.alarms) {
    const tr = document.createElement("tr");
    cell(tr, a.raised_at);
    cell(tr, a.alarm_time_s === null ? null : a.alarm_time_s + " s");
    cell(tr, a.onset_s === null ? null : a.onset_s + " s");
    cell(tr, a.leak_lpm === null ? null : a.leak_lpm.toPrecision(3) + " L/min [" +
         (a.leak_lpm_low === null ? "–" : a.leak_lpm_low.toPrecision(3)) + ", " +
         (a.leak_lpm_high === null ? "–" : a.leak_lpm_high.toPrecision(3)) + "]");
    cell(tr, a.cleared_time_s === null ? null : a.cleared_time_s + " s");
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
