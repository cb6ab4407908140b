// leakdiag live page: renders the snapshots sent by /stream/<name> (server-sent events).
// Everything received is data: it is written with textContent or handed to Plotly, never run.
"use strict";
const cfg = JSON.parse(document.getElementById("cfg").textContent);
document.getElementById("name").textContent = cfg.name;
const FEATURE_COLOR = "#1f77b4", SCORE_COLOR = "#ff7f0e";
window.leakdiagLatencies = [];

// fmtTime, fmtNum and plotlyText: format.js

function alarmShapes(s) {
  if (s.alarm_time_s === null) return [];
  const out = [{type: "line", xref: "x", yref: "paper", x0: s.alarm_time_s, x1: s.alarm_time_s,
                y0: 0, y1: 1, line: {color: "#d62728", width: 2}}];
  if (s.onset_s !== null) out.push({type: "line", xref: "x", yref: "paper", x0: s.onset_s,
    x1: s.onset_s, y0: 0, y1: 1, line: {color: "#d62728", width: 1, dash: "dot"}});
  return out;
}

function render(s) {
  const st = document.getElementById("state");
  st.textContent = s.state;
  st.className = "state " + s.state;
  document.getElementById("feature").textContent = s.feature;
  document.getElementById("alarm-time").textContent = fmtTime(s.alarm_time_s);
  document.getElementById("onset").textContent = (s.onset_censored ? "at or before " : "") +
    fmtTime(s.onset_s) + (s.onset_censored ? " (there when monitoring began)" : "");
  let leak = s.calibrated ? "–" : "no calibration";
  if (s.leak_lpm !== null) {
    leak = fmtNum(s.leak_lpm, " L/min") + " [" + fmtNum(s.leak_lpm_low, "") + ", " +
      fmtNum(s.leak_lpm_high, "") + "]" + (s.leak_interval ? " (" + s.leak_interval + ")" : "") +
      (s.leak_in_range ? "" : " (extrapolated: outside the calibrated range)");
  }
  document.getElementById("leak").textContent = leak;
  document.getElementById("last-time").textContent = fmtTime(s.last_time_s) +
    (s.done ? " (input ended)" : "");
  const shapes = alarmShapes(s);
  Plotly.react("feature-plot", [{x: s.time, y: s.value, mode: "lines", name: "feature",
    line: {color: FEATURE_COLOR, width: 2}}],
    {title: {text: plotlyText(s.feature)}, margin: {t: 40, r: 20, b: 40, l: 60}, shapes: shapes,
     xaxis: {title: {text: "time (s)"}}, yaxis: {title: {text: "feature"}}},
    {staticPlot: false, displaylogo: false});
  const traces = [{x: s.time, y: s.score, mode: "lines", name: "CUSUM score",
                   line: {color: SCORE_COLOR, width: 2}}];
  if (s.threshold !== null && s.time.length) {
    traces.push({x: [s.time[0], s.time[s.time.length - 1]], y: [s.threshold, s.threshold],
                 mode: "lines", name: "threshold", line: {color: "#000", dash: "dash"}});
  }
  Plotly.react("score-plot", traces,
    {title: {text: "detector score"}, margin: {t: 40, r: 20, b: 40, l: 60}, shapes: shapes,
     legend: {orientation: "h", x: 0, y: 1.12},
     xaxis: {title: {text: "time (s)"}}, yaxis: {title: {text: "score (healthy std)"}}},
    {displaylogo: false});
  const ul = document.getElementById("events");
  ul.replaceChildren();
  for (const e of s.events) {
    const li = document.createElement("li");
    li.className = e.kind;
    li.textContent = e.kind.toUpperCase() + (e.again ? " again" : "") + " at t=" +
      fmtTime(e.time_s) + ", score " + fmtNum(e.score, "") +
      (e.onset_s !== undefined && e.onset_s !== null ? ", onset " +
       (e.onset_censored ? "at or before " : "") + fmtTime(e.onset_s) : "");
    ul.appendChild(li);
  }
  if (s.done) {
    document.getElementById("latency").textContent = "– (input ended)";
  } else if (s.received_wall !== null) {
    const lat = Date.now() / 1000 - s.received_wall;
    window.leakdiagLatencies.push(lat);
    document.getElementById("latency").textContent = (lat * 1000).toFixed(0) + " ms";
  }
  document.body.dataset.version = String(s.version);
}

const source = new EventSource(cfg.stream);
source.onmessage = (m) => render(JSON.parse(m.data));
