// hitchpark's sweep map: every start at its pose, coloured by outcome; hover, filters, histograms, links.
// Plain JavaScript on canvases; the data is the JSON that hitchpark.viz.sweep_html embeds (sweep_data).
(function () {
  "use strict";
  const D = JSON.parse(document.getElementById("hitchpark-data").textContent);
  const K = D.cases;
  const n = K.case.length;
  const PARKED = "#009E73";
  const PALETTE = ["#D55E00", "#CC79A7", "#E69F00", "#0072B2", "#56B4E9", "#882255", "#000000"];
  const outcome = (i) => (K.success[i] ? "parked" : K.reason[i]);
  const counts = {};
  for (let i = 0; i < n; i++) counts[outcome(i)] = (counts[outcome(i)] || 0) + 1;
  const failures = Object.keys(counts).filter((k) => k !== "parked").sort((a, b) => counts[b] - counts[a] || (a < b ? -1 : 1));
  const colour = { parked: PARKED };
  failures.forEach((k, i) => { colour[k] = PALETTE[i % PALETTE.length]; });
  const shown = { parked: true, failed: true };
  for (const k of Object.keys(counts)) shown["reason:" + k] = true;
  const visible = (i) => (K.success[i] ? shown.parked : shown.failed) && shown["reason:" + outcome(i)];

  const { el, esc } = hitchpark;
  const app = document.getElementById("app");
  const parked = counts.parked || 0;
  const head = el("header");
  head.append(el("h1", {}, esc(D.title)),
    el("span", { class: "detail", id: "summary" }, `parked ${parked} of ${n} starts (${n ? ((100 * parked) / n).toFixed(1) : "–"}%)` +
      (K.link.some((l) => l) ? "; click a start to open its maneuver" : "")));
  const filters = el("div", { class: "filters" });
  const byOutcome = el("fieldset", {}, "<legend>outcome</legend>");
  const byReason = el("fieldset", {}, "<legend>reason</legend>");
  const box = (key, text, where) => {
    const input = el("input", { type: "checkbox", id: "filter-" + key.replace(/[^a-z0-9]+/gi, "-"), "data-key": key });
    input.checked = true;
    input.addEventListener("change", () => { shown[key] = input.checked; draw(); });
    const label = el("label");
    label.append(input, document.createTextNode(" " + text));
    where.append(label);
  };
  box("parked", `parked (${parked})`, byOutcome);
  box("failed", `failed (${n - parked})`, byOutcome);
  for (const k of ["parked", ...failures]) if (counts[k]) box("reason:" + k, `${k} (${counts[k]})`, byReason);
  filters.append(byOutcome, byReason);
  const main = el("div", { class: "main" });
  const map = el("canvas", { id: "map" });
  const mapBox = el("div", { class: "scene" });
  mapBox.append(map);
  main.append(mapBox);
  const hists = el("div", { class: "hists" });
  const HISTS = [["path_length_m", "path length of the trailer axle [m]"], ["planning_s", "planning time [s]"], ["switches", "direction switches"]];
  const histCanvas = HISTS.map(([key]) => { const c = el("canvas", { id: "hist-" + key }); hists.append(c); return c; });
  const tip = el("div", { class: "tip hidden", id: "tip" });
  app.append(head, filters, main, el("div", { class: "legend" }, "glyph: the trailer at its start, the tick towards the hitch; colour: outcome"), hists, tip);

  // ------------------------------------------------------------------ the map
  const ext = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
  const grow = (x, y) => { ext.x0 = Math.min(ext.x0, x); ext.x1 = Math.max(ext.x1, x); ext.y0 = Math.min(ext.y0, y); ext.y1 = Math.max(ext.y1, y); };
  for (let i = 0; i < n; i++) grow(K.x[i], K.y[i]);
  for (const [x, y] of D.space) grow(x, y);
  if (D.region) { grow(D.region.x[0], D.region.y[0]); grow(D.region.x[1], D.region.y[1]); }
  const pad = 2 + D.trailer.front;
  let T = null, drawnCount = 0;
  function sizeCanvas(c) {
    const r = window.devicePixelRatio || 1;
    const w = Math.max(50, Math.round(c.clientWidth * r)), h = Math.max(30, Math.round(c.clientHeight * r));
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
    return r;
  }
  function poly(g, pts, close) {
    g.beginPath();
    pts.forEach(([x, y], i) => (i ? g.lineTo(T.X(x), T.Y(y)) : g.moveTo(T.X(x), T.Y(y))));
    if (close) g.closePath();
  }
  function drawMap() {
    const r = sizeCanvas(map), g = map.getContext("2d"), w = map.width, h = map.height;
    const s = Math.min(w / (ext.x1 - ext.x0 + 2 * pad), h / (ext.y1 - ext.y0 + 2 * pad));
    const cx = (ext.x0 + ext.x1) / 2, cy = (ext.y0 + ext.y1) / 2;
    T = { s, r, X: (x) => w / 2 + (x - cx) * s, Y: (y) => h / 2 - (y - cy) * s };
    g.setTransform(1, 0, 0, 1, 0, 0); g.fillStyle = "#fcfcfa"; g.fillRect(0, 0, w, h);
    if (D.area) { g.setLineDash([6 * r, 4 * r]); g.strokeStyle = "#4d4d4d"; g.lineWidth = 1.2 * r; poly(g, D.area, true); g.stroke(); g.setLineDash([]); }
    for (const o of D.obstacles) { g.fillStyle = "#a6a6a6"; g.strokeStyle = "#4d4d4d"; g.lineWidth = r; poly(g, o.polygon, true); g.fill(); g.stroke(); }
    if (D.region) {
      const [x0, x1] = D.region.x, [y0, y1] = D.region.y;
      g.setLineDash([5 * r, 4 * r]); g.strokeStyle = "#7a7a7a"; g.lineWidth = r; poly(g, [[x0, y0], [x1, y0], [x1, y1], [x0, y1]], true); g.stroke(); g.setLineDash([]);
    }
    g.fillStyle = "#ececec"; g.strokeStyle = "#7a7a7a"; g.lineWidth = 1.2 * r; poly(g, D.space, true); g.fill(); g.stroke();
    const G = D.goal, tipx = G.x + 1.5 * Math.cos(G.yaw), tipy = G.y + 1.5 * Math.sin(G.yaw);
    g.strokeStyle = "#000"; g.lineWidth = 1.5 * r; poly(g, [[G.x, G.y], [tipx, tipy]]); g.stroke();
    // The glyph: the trailer body, to scale when there is room, at least a few pixels; a tick towards the hitch.
    const len = Math.max(D.trailer.front + D.trailer.rear, 10 * r / s), half = Math.max(D.trailer.width / 2, 3 * r / s);
    const front = len * D.trailer.front / (D.trailer.front + D.trailer.rear), back = len - front;
    drawnCount = 0;
    const order = [...Array(n).keys()].sort((a, b) => (K.success[b] ? 1 : 0) - (K.success[a] ? 1 : 0)); // failures on top
    for (const i of order) {
      if (!visible(i)) continue;
      const yaw = (K.yaw_deg[i] * Math.PI) / 180, c = Math.cos(yaw), sn = Math.sin(yaw), x = K.x[i], y = K.y[i];
      const at = (a, b) => [x + c * a - sn * b, y + sn * a + c * b];
      g.fillStyle = colour[outcome(i)]; g.globalAlpha = K.success[i] ? 0.55 : 0.85;
      poly(g, [at(-back, -half), at(front, -half), at(front, half), at(-back, half)], true); g.fill();
      g.globalAlpha = 1; g.strokeStyle = colour[outcome(i)]; g.lineWidth = 1.2 * r;
      poly(g, [at(front, 0), at(front + 0.6 * len, 0)]); g.stroke();
      if (K.link[i]) { g.strokeStyle = "#000"; g.lineWidth = 0.6 * r; poly(g, [at(-back, -half), at(front, -half), at(front, half), at(-back, half)], true); g.stroke(); }
      drawnCount++;
    }
    map.dataset.drawn = String(drawnCount);
  }

  function nearest(e) {
    if (!T) return -1;
    const rect = map.getBoundingClientRect(), r = map.width / rect.width;
    const px = (e.clientX - rect.left) * r, py = (e.clientY - rect.top) * r;
    let best = -1, dist = 10 * T.r;
    for (let i = 0; i < n; i++) {
      if (!visible(i)) continue;
      const d = Math.hypot(T.X(K.x[i]) - px, T.Y(K.y[i]) - py);
      if (d < dist) { dist = d; best = i; }
    }
    return best;
  }
  const num = (v, d) => (v === null ? "–" : v.toFixed(d));
  function describe(i) {
    return `case ${K.case[i]}: ${outcome(i)}\n` +
      `start x ${num(K.x[i], 2)} m, y ${num(K.y[i], 2)} m, yaw ${num(K.yaw_deg[i], 1)}°, hitch ${num(K.hitch_deg[i], 1)}°\n` +
      `path length ${num(K.path_length_m[i], 2)} m, planning ${num(K.planning_s[i], 2)} s, switches ${K.switches[i]}\n` +
      `maneuver ${num(K.maneuver_time_s[i], 1)} s, least clearance ${num(K.min_clearance_m[i], 3)} m, max |hitch| ${num(K.max_abs_hitch_deg[i], 1)}°` +
      (K.link[i] ? "\nclick to open its maneuver" : "");
  }
  map.addEventListener("mousemove", (e) => {
    const i = nearest(e);
    if (i < 0) { tip.classList.add("hidden"); map.style.cursor = "default"; return; }
    tip.textContent = describe(i);
    tip.style.left = e.clientX + 14 + "px"; tip.style.top = e.clientY + 10 + "px";
    tip.classList.remove("hidden");
    tip.dataset.case = String(K.case[i]);
    map.style.cursor = K.link[i] ? "pointer" : "default";
  });
  map.addEventListener("mouseleave", () => tip.classList.add("hidden"));
  map.addEventListener("click", (e) => { const i = nearest(e); if (i >= 0 && K.link[i]) window.location.href = K.link[i]; });

  // ------------------------------------------------------------------ the histograms
  function drawHist(c, key, label) {
    const r = sizeCanvas(c), g = c.getContext("2d"), w = c.width, h = c.height;
    g.setTransform(1, 0, 0, 1, 0, 0); g.clearRect(0, 0, w, h);
    const values = [];
    for (let i = 0; i < n; i++) if (visible(i) && K[key][i] !== null) values.push([K[key][i], K.success[i]]);
    g.fillStyle = "#333"; g.font = `${11 * r}px system-ui, sans-serif`; g.textBaseline = "top"; g.fillText(`${label} (${values.length})`, 6 * r, 4 * r);
    if (!values.length) return;
    let lo = Math.min(...values.map((v) => v[0])), hi = Math.max(...values.map((v) => v[0]));
    const integer = key === "switches";
    if (!integer && hi <= lo) hi = lo + 1;
    const bins = integer ? Math.min(40, hi - lo + 1) : 24;
    const width = integer ? Math.max(1, Math.ceil((hi - lo + 1) / bins)) : (hi - lo) / bins;
    const ok = new Array(bins).fill(0), bad = new Array(bins).fill(0);
    for (const [v, s] of values) { const b = Math.min(bins - 1, Math.floor((v - lo) / width)); (s ? ok : bad)[b]++; }
    const top = Math.max(...ok.map((v, i) => v + bad[i])), left = 8 * r, bottom = h - 18 * r, y0 = 20 * r, bw = (w - 2 * left) / bins;
    for (let b = 0; b < bins; b++) {
      const hOk = ((bottom - y0) * ok[b]) / top, hBad = ((bottom - y0) * bad[b]) / top;
      g.fillStyle = PARKED; g.fillRect(left + b * bw, bottom - hOk, bw - r, hOk);
      g.fillStyle = "#D55E00"; g.fillRect(left + b * bw, bottom - hOk - hBad, bw - r, hBad);
    }
    g.fillStyle = "#333"; g.textBaseline = "top"; g.textAlign = "left"; g.fillText(num(lo, integer ? 0 : 2), left, bottom + 3 * r);
    g.textAlign = "right"; g.fillText(num(integer ? lo + bins * width - 1 : hi, integer ? 0 : 2), w - left, bottom + 3 * r); g.textAlign = "left";
  }
  function draw() {
    drawMap();
    HISTS.forEach(([key, label], j) => drawHist(histCanvas[j], key, label));
  }
  window.addEventListener("resize", draw);
  // For scripts and tests: where a case's start is on the screen (client pixels).
  const screenOf = (i) => {
    const rect = map.getBoundingClientRect(), r = map.width / rect.width;
    return [rect.left + T.X(K.x[i]) / r, rect.top + T.Y(K.y[i]) / r];
  };
  window.hitchsweep = { data: D, shown, visible, draw, screenOf };
  draw();
  document.body.dataset.ready = "1";
})();
