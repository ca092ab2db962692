// The live page of ssrfleet serve: polls /api/summary every second and, when the checkpoint
// changes, fetches what depends on it. Every figure comes from the JSON API (docs/serve.md); the
// counts the browser test reads are kept in data-* attributes.
"use strict";

const POLL_MS = 1000;
const DAMAGE_EVERY_MS = 3000;  // the damage is a simulation: asked for at most this often
const HYPER_NAMES = { K: "K: fleet mean suspension stiffness", sigma_k: "σk: its spread", Kt: "Kt: fleet mean tyre stiffness",
  sigma_kt: "σkt: its spread", Z: "Z: fleet mean lateral position", sigma_z: "σz: its spread",
  sigma_if: "σIF: impact-factor noise of the sensors" };

const view = { state: null, cls: "", site: "", seq: -1, rejected: -1, damageAt: 0, damageSeq: -1, damageWanted: false,
  charts: {}, states: [], positions: "", positionsWanted: false };

const $ = (id) => document.getElementById(id);
const fmt = (v, digits = 4) => (v === null || v === undefined ? "–" : Number(v).toPrecision(digits));

function query(extra) {
  const p = new URLSearchParams();
  if (view.states.length > 1 && view.state) p.set("state", view.state);
  for (const [k, v] of Object.entries(extra || {})) if (v !== "" && v !== undefined && v !== null) p.set(k, v);
  const s = p.toString();
  return s ? "?" + s : "";
}

async function getJson(path, extra) {
  const r = await fetch(path + query(extra), { cache: "no-store" });
  const body = await r.json();
  return { status: r.status, body };
}

function setStatus(kind, text) {
  const s = $("status");
  s.className = "status " + kind;
  s.textContent = text;
  document.body.dataset.status = kind;
}

function lineChart(canvas, xLabel, yLabel) {
  return new Chart(canvas, {
    type: "scatter",
    data: { datasets: [] },
    options: {
      animation: false, responsive: true, maintainAspectRatio: false, parsing: false, normalized: true,
      plugins: { legend: { display: true, labels: { boxWidth: 12, font: { size: 11 } } }, tooltip: { mode: "nearest" } },
      scales: { x: { type: "linear", title: { display: true, text: xLabel } }, y: { title: { display: true, text: yLabel } } },
    },
  });
}

function band(label, xs, lo, hi, color) {
  return [
    { label: label, data: xs.map((x, i) => ({ x, y: lo[i] })), showLine: true, pointRadius: 0, borderWidth: 0,
      borderColor: color, backgroundColor: color + "33", fill: false },
    { label: "_hi", data: xs.map((x, i) => ({ x, y: hi[i] })), showLine: true, pointRadius: 0, borderWidth: 0,
      borderColor: color, backgroundColor: color + "33", fill: "-1" },
  ];
}

function hideHelpers(chart) {
  chart.options.plugins.legend.labels.filter = (item) => !item.text.startsWith("_");
}

function drawSsr(ssr) {
  if (!view.charts.ssr) {
    view.charts.ssr = lineChart($("ssr-chart"), "position along the road (m)", "impact factor");
    hideHelpers(view.charts.ssr);
  }
  const x = ssr.position_m;
  const mean = { label: "mean IF (the SSR pattern)", data: x.map((p, i) => ({ x: p, y: ssr.mean_if[i] })), showLine: true,
    borderColor: "#1f6feb", backgroundColor: "#1f6feb", pointRadius: 3, borderWidth: 2 };
  view.charts.ssr.data.datasets = [
    ...band("95 % limits, one truck", x, ssr.lower95, ssr.upper95, "#8c959f"),
    ...band("95 % band of the mean", x, ssr.mean_lower95, ssr.mean_upper95, "#1f6feb"),
    mean,
  ];
  view.charts.ssr.update();
  $("ssr-chart").dataset.points = String(x.length);
}

function drawHistory(series) {
  const grid = $("hyper-grid");
  for (const s of series) {
    let chart = view.charts["h_" + s.name];
    if (!chart) {
      const box = document.createElement("div");
      box.className = "chart-box";
      const canvas = document.createElement("canvas");
      canvas.id = "hyper-" + s.name;
      box.appendChild(canvas);
      grid.appendChild(box);
      chart = lineChart(canvas, "trucks absorbed", s.unit === "1" ? "–" : s.unit || "");
      chart.options.plugins.legend.display = false;
      chart.options.plugins.title = { display: true, text: HYPER_NAMES[s.name] || s.name, font: { size: 12 } };
      view.charts["h_" + s.name] = chart;
    }
    chart.data.datasets = [
      ...band("95 %", s.trucks, s.q025, s.q975, "#1a7f37"),
      { label: "mean", data: s.trucks.map((t, i) => ({ x: t, y: s.mean[i] })), showLine: true, pointRadius: 0,
        borderColor: "#1a7f37", borderWidth: 2 },
    ];
    chart.update();
    chart.canvas.dataset.points = String(s.trucks.length);
  }
}

function fillTable(id, rows, empty, columns) {
  const body = $(id).querySelector("tbody");
  body.replaceChildren();
  if (rows.length === 0) {
    const tr = body.insertRow();
    const td = tr.insertCell();
    td.colSpan = columns;
    td.className = "note";
    td.textContent = empty;
    return;
  }
  for (const cells of rows) {
    const tr = body.insertRow();
    for (const c of cells) {
      const td = tr.insertCell();
      td.textContent = c;
    }
  }
}

function selector(pickId, selectId, values, current, labelOf) {
  const show = values.length > 1;
  $(pickId).hidden = !show;
  const sel = $(selectId);
  const want = values.join("\n");
  if (sel.dataset.values !== want) {
    sel.replaceChildren();
    for (const v of values) sel.add(new Option(labelOf(v), v));
    sel.dataset.values = want;
  }
  sel.value = current;
}

async function refreshRejects() {
  const { body } = await getJson("/api/rejects", { limit: 10 });
  fillTable("rejects-table", body.last.slice().reverse().map((r) => [String(r.line), r.field, r.reason]),
    "none", 3);
}

async function refreshDamage() {
  view.damageAt = Date.now();
  const { status, body } = await getJson("/api/damage", { class: view.cls, site: view.site });
  if (status === 202) { view.damageWanted = true; $("damage-note").textContent = "computing…"; return; }
  if (status !== 200) { $("damage-note").textContent = body.error || ""; return; }
  view.damageWanted = !body.current;
  view.damageSeq = body.checkpoint.seq;
  $("damage-note").textContent = "after " + body.checkpoint.trucks + " trucks; a hot spot: the 95th percentile of " +
    "a₄ over the posterior above " + body.hot_spot_threshold;
  fillTable("damage-table", body.hot_spots.map((h) => [String(h.position_m), fmt(h.a4), fmt(h.a4_q975),
    fmt(h.esal_per_million)]), "no hot spot (a₄ stays under " + body.hot_spot_threshold + " everywhere)", 4);
  $("damage-table").dataset.hotSpots = String(body.hot_spots.length);
}

async function refreshPositions() {
  if (!view.positions) return;
  const { status, body } = await getJson("/api/ssr", { positions: view.positions, class: view.cls, site: view.site });
  view.positionsWanted = status === 202 || (status === 200 && !body.current);  // asked again next second
  if (status === 202) { $("positions-status").textContent = "computing…"; return; }
  if (status !== 200) { $("positions-status").textContent = body.error + " (" + body.parameter + ")"; return; }
  $("positions-status").textContent = "after " + body.checkpoint.trucks + " trucks" + (body.current ? "" : " (updating)");
  const s = body.ssr;
  $("positions-table").hidden = false;
  fillTable("positions-table", s.position_m.map((p, i) => [String(p), fmt(s.mean_if[i]),
    fmt(s.lower95[i]) + " – " + fmt(s.upper95[i]), fmt(s.mean_lower95[i]) + " – " + fmt(s.mean_upper95[i])]), "", 4);
}

async function onCheckpoint() {
  const ssr = await getJson("/api/ssr", { class: view.cls, site: view.site });
  if (ssr.status === 200) {
    drawSsr(ssr.body.ssr);
    $("ssr-note").textContent = (ssr.body.source === "history" ? "at the sensors" : "computed") + ", after " +
      ssr.body.checkpoint.trucks + " trucks" + (ssr.body.current ? "" : " (updating)");
  } else if (ssr.status === 202) {
    $("ssr-note").textContent = "computing…";
    view.seq = -1;  // ask again next time
  }
  const hist = await getJson("/api/history", { class: view.cls, points: 300 });
  if (hist.status === 200) drawHistory(hist.body.series);
  await refreshPositions();
}

async function tick() {
  try {
    if (view.states.length === 0) {
      view.states = (await getJson("/api/states")).body.states;
      view.state = view.states[0].name;
      selector("state-pick", "state-select", view.states.map((s) => s.name), view.state, (v) => v);
      $("state-dir").textContent = view.states[0].dir;
    }
    const { status, body } = await getJson("/api/summary");
    if (status !== 200) throw new Error(body.error || "HTTP " + status);
    const cp = body.checkpoint;
    const words = { running: "Stream running", idle: "Stream running but idle: no new truck for a while",
      stopped: "STREAM STOPPED: no process holds the state's lock; the figures are its last checkpoint's",
      waiting: "Waiting for the stream's first checkpoint" };
    setStatus(body.error ? "error" : body.status, body.error ? "Cannot read the state: " + body.error :
      words[body.status] + (body.lock_pid ? " (process " + body.lock_pid + ")" : ""));
    const classes = body.classes || [];
    selector("class-pick", "class-select", classes.length > 1 || (classes[0] || "") !== "" ? ["", ...classes] : [],
      view.cls, (v) => (v === "" ? "all classes (mixture)" : v));
    selector("site-pick", "site-select", body.sites.length > 1 ? body.sites : [], view.site || body.sites[0],
      (v) => v);
    $("rejected").textContent = String(body.rejected);
    $("rejected").dataset.rejected = String(body.rejected);
    if (body.rejected !== view.rejected) { view.rejected = body.rejected; await refreshRejects(); }
    if (!cp) return;
    $("trucks").textContent = cp.trucks.toLocaleString("en");
    $("trucks").dataset.trucks = String(cp.trucks);
    document.body.dataset.seq = String(cp.seq);
    $("rate").textContent = body.trucks_per_min.toFixed(1);
    $("ess").textContent = Math.round(cp.ess).toString();
    $("age").textContent = cp.age_s < 90 ? Math.round(cp.age_s) + " s ago" : new Date(cp.time_s * 1000).toLocaleString();
    $("model").textContent = body.model;
    if (cp.seq !== view.seq) {
      noteCheckpoint(cp);
      view.seq = cp.seq;
      await onCheckpoint();
    } else if (view.positionsWanted) {
      await refreshPositions();
    }
    if ((cp.seq !== view.damageSeq || view.damageWanted) && Date.now() - view.damageAt >= DAMAGE_EVERY_MS) {
      await refreshDamage();
    }
  } catch (e) {
    setStatus("unreachable", "Cannot reach the ssrfleet server (" + e.message + "); trying again every second");
  } finally {
    setTimeout(tick, POLL_MS);
  }
}

// What the browser test reads: the trucks at the first checkpoint this page saw, how many new
// checkpoints it showed since without a reload, and the longest delay from a checkpoint's report
// being written to the page showing it.
function noteCheckpoint(cp) {
  const d = document.body.dataset;
  if (d.firstTrucks === undefined) { d.firstTrucks = String(cp.trucks); d.updates = "0"; d.maxLagMs = "0"; return; }
  if (view.seq === -1) return;  // a selection changed: the same checkpoint drawn again
  d.updates = String(Number(d.updates) + 1);
  d.maxLagMs = String(Math.max(Number(d.maxLagMs), Math.round(Date.now() - cp.time_s * 1000)));
}

function reset() { view.seq = -1; view.damageSeq = -1; view.damageAt = 0; }
$("state-select").addEventListener("change", (e) => { view.state = e.target.value; view.rejected = -1; reset(); });
$("class-select").addEventListener("change", (e) => { view.cls = e.target.value; reset(); });
$("site-select").addEventListener("change", (e) => { view.site = e.target.value; reset(); });
$("positions-form").addEventListener("submit", (e) => {
  e.preventDefault();
  view.positions = $("positions").value.trim();
  refreshPositions();
});
tick();
