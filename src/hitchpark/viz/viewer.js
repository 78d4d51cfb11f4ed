// hitchpark's maneuver viewer: the scene to scale, the rig at the cursor, plots synced to a timeline.
// Plain JavaScript on canvases; the data is the JSON that hitchpark.viz.viewer embeds (viewer_data).
(function () {
  "use strict";
  const D = JSON.parse(document.getElementById("hitchpark-data").textContent);
  const C = D.columns;
  const n = C.t.length;
  const DEG = 180 / Math.PI;
  const COLORS = { vehicleFace: "#c6dbef", vehicleEdge: "#08306b", trailerFace: "#fdd9b5", trailerEdge: "#7f2704",
    wheel: "#303030", obstacleFace: "#a6a6a6", obstacleEdge: "#4d4d4d", spaceFace: "#ececec", spaceEdge: "#7a7a7a",
    limit: "#b22222", plan: "#303030", prediction: "#c51b7d", command: "#e69f00" };
  const view = { row: 0, playing: false, speed: 1, layers: { plan: true, predictions: true, paths: true, clearance: true },
    drawn: [], zoom: 1, panX: 0, panY: 0 };

  // ------------------------------------------------------------------ the page
  const { el, esc } = hitchpark;
  const app = document.getElementById("app");
  const head = el("header");
  head.append(el("h1", {}, esc(D.name || "maneuver")),
    el("span", { class: "badge " + (D.success ? "good" : "bad"), id: "outcome" }, esc(D.success ? "parked" : D.reason)),
    el("span", { class: "detail", id: "detail" }, esc(D.detail || "")));
  const main = el("div", { class: "main" });
  const sceneBox = el("div", { class: "scene" });
  const scene = el("canvas", { id: "scene" });
  sceneBox.append(scene);
  const aside = el("aside", { id: "readout" });
  main.append(sceneBox, aside);
  const controls = el("div", { class: "controls" });
  const play = el("button", { id: "play", type: "button" }, "Play");
  const slider = el("input", { id: "timeline", type: "range", min: "0", max: String(n - 1), step: "1", value: "0" });
  const speed = el("select", { id: "speed" });
  for (const s of [0.5, 1, 2, 4, 8]) speed.append(el("option", s === 1 ? { value: s, selected: "" } : { value: s }, "×" + s));
  const time = el("span", { class: "time", id: "time" });
  controls.append(play, slider, speed, time);
  const layers = el("div", { class: "controls layers" });
  const available = { plan: D.plans.length > 0, predictions: !!D.predictions, paths: true, clearance: !!D.clearance };
  for (const name of Object.keys(view.layers)) {
    const box = el("input", { type: "checkbox", id: "layer-" + name, "data-layer": name });
    box.checked = true;
    box.disabled = !available[name];
    box.addEventListener("change", () => { view.layers[name] = box.checked; layout(); draw(); });
    const label = el("label", { title: available[name] ? "" : "not in this record" });
    label.append(box, document.createTextNode(" " + name + (available[name] ? "" : " (none)")));
    layers.append(label);
  }
  layers.append(el("span", { class: "detail" }, "← → one tick, space plays; wheel zooms, drag pans, double-click resets"));
  const plotsBox = el("div", { class: "plots" });
  const legend = el("div", { class: "legend" },
    "solid: actual, dashed orange: commanded; red dashed: limits; shaded by stage");
  app.append(head, main, controls, layers, legend, plotsBox);

  // ------------------------------------------------------------------ derived series
  const rate = new Array(n).fill(null); // steer rate: difference of front_steer over dt
  for (let k = 0; k + 1 < n; k++) {
    const dt = C.t[k + 1] - C.t[k];
    if (dt > 0) rate[k] = (C.front_steer[k + 1] - C.front_steer[k]) / dt;
  }
  const deg = (a) => a.map((v) => (v === null ? null : v * DEG));
  const L = D.limits;
  const plots = [
    { id: "plot-steer", label: "front steer [deg]", series: [[deg(C.front_steer), "#0b3d91", []], [deg(C.front_steer_cmd), COLORS.command, [5, 3]]], limits: [L.max_steer * DEG] },
    { id: "plot-rate", label: "steer rate [deg/s]", series: [[deg(rate), "#0b3d91", []]], limits: [L.max_steer_rate * DEG] },
    { id: "plot-speed", label: "rear-axle speed [m/s]", series: [[C.rear_speed, "#0b3d91", []], [C.rear_speed_cmd, COLORS.command, [5, 3]]], limits: [] },
    { id: "plot-hitch", label: "hitch [deg] vs jackknife limit", series: [[deg(C.hitch), "#0b3d91", []]], limits: [L.max_hitch * DEG] },
  ];
  if (D.clearance) {
    plots.push({ id: "plot-clearance", label: "clearance [m] vs min_clearance_m", layer: "clearance",
      series: [[D.clearance.rows, "#0b3d91", []]], limits: [L.min_clearance_m], oneSided: true, floor: 0 });
  }
  for (const p of plots) {
    p.canvas = el("canvas", { id: p.id });
    plotsBox.append(p.canvas);
    p.canvas.addEventListener("mousedown", (e) => scrub(p, e));
    p.canvas.addEventListener("mousemove", (e) => { if (e.buttons & 1) scrub(p, e); });
  }

  // ------------------------------------------------------------------ geometry
  const rot = (pts, x, y, yaw) => {
    const c = Math.cos(yaw), s = Math.sin(yaw);
    return pts.map(([px, py]) => [x + c * px - s * py, y + s * px + c * py]);
  };
  const extent = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
  const grow = (x, y) => {
    if (x === null || y === null) return;
    extent.x0 = Math.min(extent.x0, x); extent.x1 = Math.max(extent.x1, x);
    extent.y0 = Math.min(extent.y0, y); extent.y1 = Math.max(extent.y1, y);
  };
  for (let k = 0; k < n; k++) { grow(C.x_trailer[k], C.y_trailer[k]); grow(C.x_rear[k], C.y_rear[k]); }
  for (const [x, y] of D.goal.space) grow(x, y);
  const reach = Math.max(...D.shapes.vehicle.map(([x, y]) => Math.hypot(x, y)), ...D.shapes.trailer.map(([x, y]) => Math.hypot(x, y)));
  const margin = reach + 1.5;

  function sizeCanvas(c) {
    const r = window.devicePixelRatio || 1;
    const w = Math.max(50, Math.round(c.clientWidth * r)), h = Math.max(30, Math.round(c.clientHeight * r));
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
    return r;
  }

  function transform() {
    const w = scene.width, h = scene.height;
    const ex = extent.x1 - extent.x0 + 2 * margin, ey = extent.y1 - extent.y0 + 2 * margin;
    const s = Math.min(w / ex, h / ey) * view.zoom;
    const cx = (extent.x0 + extent.x1) / 2 + view.panX, cy = (extent.y0 + extent.y1) / 2 + view.panY;
    return { s, X: (x) => w / 2 + (x - cx) * s, Y: (y) => h / 2 - (y - cy) * s };
  }

  function poly(g, T, pts, close) {
    g.beginPath();
    pts.forEach(([x, y], i) => (i ? g.lineTo(T.X(x), T.Y(y)) : g.moveTo(T.X(x), T.Y(y))));
    if (close) g.closePath();
  }

  function line(g, T, xs, ys, from, to) {
    g.beginPath();
    let pen = false;
    for (let k = from; k < to; k++) {
      if (xs[k] === null || ys[k] === null) { pen = false; continue; }
      pen ? g.lineTo(T.X(xs[k]), T.Y(ys[k])) : g.moveTo(T.X(xs[k]), T.Y(ys[k]));
      pen = true;
    }
    g.stroke();
  }

  // ------------------------------------------------------------------ the scene
  function drawScene() {
    const r = sizeCanvas(scene);
    const g = scene.getContext("2d");
    const T = transform();
    const drawn = [];
    g.setTransform(1, 0, 0, 1, 0, 0);
    g.fillStyle = "#fcfcfa"; g.fillRect(0, 0, scene.width, scene.height);
    g.lineJoin = "round"; g.lineCap = "round";
    if (D.area) { g.setLineDash([6 * r, 4 * r]); g.strokeStyle = COLORS.obstacleEdge; g.lineWidth = 1.2 * r; poly(g, T, D.area, true); g.stroke(); g.setLineDash([]); }
    g.font = `${11 * r}px system-ui, sans-serif`; g.textAlign = "center"; g.textBaseline = "middle";
    for (const o of D.obstacles) {
      g.fillStyle = COLORS.obstacleFace; g.strokeStyle = COLORS.obstacleEdge; g.lineWidth = r;
      poly(g, T, o.polygon, true); g.fill(); g.stroke();
      if (o.name) {
        const cx = o.polygon.slice(0, -1).reduce((a, p) => a + p[0], 0) / (o.polygon.length - 1);
        const cy = o.polygon.slice(0, -1).reduce((a, p) => a + p[1], 0) / (o.polygon.length - 1);
        g.fillStyle = "#1a1a1a"; g.fillText(o.name, T.X(cx), T.Y(cy));
      }
    }
    g.fillStyle = COLORS.spaceFace; g.strokeStyle = COLORS.spaceEdge; g.lineWidth = 1.2 * r; g.setLineDash([6 * r, 3 * r]);
    poly(g, T, D.goal.space, true); g.fill(); g.stroke(); g.setLineDash([]);
    const gx = D.goal.x, gy = D.goal.y, tip = [gx + D.arrow * Math.cos(D.goal.yaw), gy + D.arrow * Math.sin(D.goal.yaw)];
    g.strokeStyle = "#222"; g.lineWidth = 1.4 * r; poly(g, T, [[gx, gy], tip]); g.stroke();
    g.beginPath(); g.arc(T.X(tip[0]), T.Y(tip[1]), 3 * r, 0, 2 * Math.PI); g.fillStyle = "#222"; g.fill();
    const c = 5 * r; g.beginPath(); g.moveTo(T.X(gx) - c, T.Y(gy)); g.lineTo(T.X(gx) + c, T.Y(gy));
    g.moveTo(T.X(gx), T.Y(gy) - c); g.lineTo(T.X(gx), T.Y(gy) + c); g.stroke();
    if (view.layers.plan && D.plans.length) {
      g.strokeStyle = COLORS.plan; g.globalAlpha = 0.8; g.lineWidth = 1.2 * r; g.setLineDash([5 * r, 3 * r]);
      for (const p of D.plans) line(g, T, p.x, p.y, 0, p.x.length);
      g.setLineDash([]); g.globalAlpha = 1; drawn.push("plan");
    }
    if (view.layers.paths) {
      for (const [i, st] of D.stages.entries()) {
        const color = D.stage_colors[i % D.stage_colors.length];
        const a = st.first_row, b = st.last_row + 1, now = Math.min(b, view.row + 1);
        for (const [xs, ys, w, dash] of [[C.x_trailer, C.y_trailer, 2.2, []], [C.x_rear, C.y_rear, 1.3, [4, 2]]]) {
          g.strokeStyle = color; g.lineWidth = w * r; g.setLineDash(dash.map((d) => d * r));
          g.globalAlpha = 0.25; line(g, T, xs, ys, a, b);
          if (now > a) { g.globalAlpha = 1; line(g, T, xs, ys, a, now); }
        }
      }
      g.setLineDash([]); g.globalAlpha = 1; drawn.push("paths");
    }
    drawRig(g, T, r);
    if (view.layers.clearance && D.clearance && D.clearance.points) {
      const [[bx, by], [ox, oy]] = D.clearance.points;
      g.strokeStyle = COLORS.limit; g.lineWidth = 1.6 * r; poly(g, T, [[bx, by], [ox, oy]]); g.stroke();
      g.fillStyle = COLORS.limit; g.textAlign = "left";
      g.fillText(`least clearance ${fmtLen(D.clearance.least)}`, T.X(bx) + 6 * r, T.Y(by) - 8 * r);
      drawn.push("clearance");
    }
    const pred = D.predictions && D.predictions[view.row];
    if (view.layers.predictions && pred && pred.length) {
      g.strokeStyle = COLORS.prediction; g.fillStyle = COLORS.prediction; g.lineWidth = 1.8 * r;
      poly(g, T, pred); g.stroke();
      for (const [x, y] of pred) { g.beginPath(); g.arc(T.X(x), T.Y(y), 2.2 * r, 0, 2 * Math.PI); g.fill(); }
      drawn.push("predictions");
    }
    view.drawn = drawn;
  }

  function drawRig(g, T, r) {
    const k = view.row, S = D.shapes;
    const tr = (pts) => rot(pts, C.x_trailer[k], C.y_trailer[k], C.yaw_trailer[k]);
    const car = (pts) => rot(pts, C.x_rear[k], C.y_rear[k], C.yaw_vehicle[k]);
    g.fillStyle = COLORS.wheel;
    const wheels = [...S.trailer_wheels.map(tr), ...S.rear_wheels.map(car),
      ...S.front_wheels.map((w, i) => car(rot(w, S.front_centres[i][0], S.front_centres[i][1], C.front_steer[k])))];
    for (const w of wheels) { poly(g, T, w, true); g.fill(); }
    g.lineWidth = 1.4 * r; g.globalAlpha = 0.85;
    g.fillStyle = COLORS.trailerFace; g.strokeStyle = COLORS.trailerEdge; poly(g, T, tr(S.trailer), true); g.fill(); g.stroke();
    g.fillStyle = COLORS.vehicleFace; g.strokeStyle = COLORS.vehicleEdge; poly(g, T, car(S.vehicle), true); g.fill(); g.stroke();
    g.globalAlpha = 1; g.strokeStyle = "#404040"; g.lineWidth = 1.8 * r;
    poly(g, T, tr(S.drawbar)); g.stroke(); poly(g, T, car(S.tow_bar)); g.stroke();
    const [hx, hy] = car([S.hitch])[0];
    g.fillStyle = "#000"; g.beginPath(); g.arc(T.X(hx), T.Y(hy), 2.5 * r, 0, 2 * Math.PI); g.fill();
  }

  // ------------------------------------------------------------------ the plots
  function drawPlot(p) {
    if (p.layer && !view.layers[p.layer]) return;
    const r = sizeCanvas(p.canvas);
    const g = p.canvas.getContext("2d");
    const w = p.canvas.width, h = p.canvas.height, left = 52 * r, right = 8 * r, top = 14 * r, bottom = 14 * r;
    g.setTransform(1, 0, 0, 1, 0, 0); g.clearRect(0, 0, w, h);
    let lo = Infinity, hi = -Infinity;
    for (const [ys] of p.series) for (const v of ys) if (v !== null) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    for (const lim of p.limits) { hi = Math.max(hi, lim * 1.05); if (!p.oneSided) lo = Math.min(lo, -lim * 1.05); }
    if (p.floor !== undefined) lo = Math.min(lo, p.floor);
    if (!isFinite(lo)) { lo = -1; hi = 1; }
    if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
    const t0 = C.t[0], t1 = C.t[n - 1] > t0 ? C.t[n - 1] : t0 + 1;
    const X = (t) => left + ((t - t0) / (t1 - t0)) * (w - left - right);
    const Y = (v) => top + (1 - (v - lo) / (hi - lo)) * (h - top - bottom);
    p.X = X; p.t0 = t0; p.t1 = t1; p.left = left; p.right = right;
    for (const [i, st] of D.stages.entries()) {
      g.fillStyle = D.stage_colors[i % D.stage_colors.length]; g.globalAlpha = 0.07;
      g.fillRect(X(C.t[st.first_row]), top, X(C.t[st.last_row]) - X(C.t[st.first_row]), h - top - bottom);
    }
    g.globalAlpha = 1; g.strokeStyle = "#ccc"; g.lineWidth = r;
    g.beginPath(); g.moveTo(left, Y(0)); g.lineTo(w - right, Y(0)); g.stroke();
    g.strokeStyle = COLORS.limit; g.setLineDash([4 * r, 3 * r]);
    for (const lim of p.limits) {
      for (const v of p.oneSided ? [lim] : [lim, -lim]) { g.beginPath(); g.moveTo(left, Y(v)); g.lineTo(w - right, Y(v)); g.stroke(); }
    }
    for (const [ys, color, dash] of p.series) {
      g.strokeStyle = color; g.lineWidth = 1.4 * r; g.setLineDash(dash.map((d) => d * r));
      g.beginPath(); let pen = false;
      for (let k = 0; k < n; k++) {
        if (ys[k] === null) { pen = false; continue; }
        pen ? g.lineTo(X(C.t[k]), Y(ys[k])) : g.moveTo(X(C.t[k]), Y(ys[k])); pen = true;
      }
      g.stroke();
    }
    g.setLineDash([]);
    g.fillStyle = "#333"; g.font = `${11 * r}px system-ui, sans-serif`; g.textAlign = "left"; g.textBaseline = "top";
    g.fillText(p.label, left + 4 * r, 1 * r);
    g.textAlign = "right"; g.textBaseline = "middle";
    g.fillText(num(hi), left - 4 * r, Y(hi)); g.fillText(num(lo), left - 4 * r, Y(lo));
    g.strokeStyle = "#000"; g.lineWidth = 1.2 * r;
    g.beginPath(); g.moveTo(X(C.t[view.row]), top); g.lineTo(X(C.t[view.row]), h - bottom); g.stroke();
  }

  function scrub(p, e) {
    if (!p.X) return;
    const rect = p.canvas.getBoundingClientRect(), r = p.canvas.width / rect.width;
    const x = (e.clientX - rect.left) * r;
    const t = p.t0 + ((x - p.left) / (p.canvas.width - p.left - p.right)) * (p.t1 - p.t0);
    setRow(rowAt(t));
  }

  // ------------------------------------------------------------------ the readout
  const num = (v, d = 2) => (v === null || v === undefined ? "–" : Math.abs(v) >= 100 ? v.toFixed(0) : v.toFixed(d));
  const fmtLen = (m) => (m === 0 ? "0 (collision)" : m < 1 ? (100 * m).toFixed(1) + " cm" : m.toFixed(2) + " m");
  function stageOf(k) {
    for (let i = D.stages.length - 1; i >= 0; i--) if (D.stages[i].first_row <= k) return i;
    return 0;
  }
  function readout() {
    const k = view.row, st = D.stages[stageOf(k)], hitch = C.hitch[k] * DEG, lim = L.max_hitch * DEG;
    const rows = [
      ["t", num(C.t[k]) + " s"], ["row", `${k} / ${n - 1}`],
      ["trailer x, y", `${num(C.x_trailer[k])}, ${num(C.y_trailer[k])} m`],
      ["trailer yaw", num(C.yaw_trailer[k] * DEG, 1) + "°"],
      ["hitch", `<span class="${Math.abs(hitch) > lim ? "over" : ""}">${num(hitch, 1)}°</span> (limit ±${num(lim, 1)}°)`],
      ["steer / cmd", `${num(C.front_steer[k] * DEG, 1)}° / ${num(C.front_steer_cmd[k] * DEG, 1)}°`],
      ["steer rate", rate[k] === null ? "–" : num(rate[k] * DEG, 1) + "°/s"],
      ["speed / cmd", `${num(C.rear_speed[k])} / ${num(C.rear_speed_cmd[k])} m/s`],
      ["hitch measured", num(C.hitch_measured[k] * DEG, 1) + "°" + (C.hitch_doubt && C.hitch_doubt[k] > 0 ? ` ± ${num(C.hitch_doubt[k] * DEG, 1)}°` : "")],
      ["NMPC cost, solve", C.cost[k] === null ? "–" : `${num(C.cost[k], 3)}, ${num(C.solve_ms[k], 1)} ms`],
    ];
    if (D.clearance) {
      const cl = D.clearance.rows[k];
      rows.push(["clearance", `<span class="${cl !== null && cl < L.min_clearance_m ? "over" : ""}">${cl === null ? "–" : fmtLen(cl)}</span>`]);
    }
    if (D.predictions) rows.push(["prediction", D.predictions[k] && D.predictions[k].length ? `${D.predictions[k].length} steps` : "none at this row"]);
    const table = rows.map(([a, b]) => `<tr><td>${a}</td><td class="v">${b}</td></tr>`).join("");
    aside.innerHTML = `<h2>At the cursor</h2><table>${table}</table>` +
      `<h2>Stage</h2><div id="stage">${esc(st.name)}</div><div class="detail">ended: ${esc(st.reason)}</div>` +
      `<h2>Outcome</h2><div>${esc(D.reason)}${D.success ? " (parked)" : ""}</div><div class="detail">${esc(D.detail || "")}</div>`;
    time.textContent = `${num(C.t[k])} / ${num(C.t[n - 1])} s`;
  }

  // ------------------------------------------------------------------ time
  function rowAt(t) {
    let lo = 0, hi = n - 1;
    if (t <= C.t[0]) return 0;
    while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (C.t[mid] <= t) lo = mid; else hi = mid - 1; }
    return lo;
  }
  function setRow(k) {
    view.row = Math.max(0, Math.min(n - 1, k | 0));
    view.clock = C.t[view.row];
    slider.value = String(view.row);
    document.body.dataset.row = String(view.row);
    draw();
  }
  let last = null;
  function tick(now) {
    if (!view.playing) { last = null; return; }
    if (last !== null) {
      view.clock += ((now - last) / 1000) * view.speed;
      const k = rowAt(view.clock);
      if (k !== view.row) { view.row = k; slider.value = String(k); document.body.dataset.row = String(k); draw(); }
      if (view.row >= n - 1) { setPlaying(false); return; }
    }
    last = now;
    requestAnimationFrame(tick);
  }
  function setPlaying(on) {
    if (on && view.row >= n - 1) setRow(0);
    view.playing = on;
    play.textContent = on ? "Pause" : "Play";
    if (on) { view.clock = C.t[view.row]; requestAnimationFrame(tick); }
  }
  play.addEventListener("click", () => setPlaying(!view.playing));
  slider.addEventListener("input", () => setRow(+slider.value));
  speed.addEventListener("change", () => { view.speed = +speed.value; });
  document.addEventListener("keydown", (e) => {
    if (e.target.tagName === "SELECT") return;
    if (e.key === "ArrowRight" || e.key === "ArrowLeft") {
      e.preventDefault(); setPlaying(false); setRow(view.row + (e.key === "ArrowRight" ? 1 : -1));
    } else if (e.key === " ") { e.preventDefault(); setPlaying(!view.playing); }
  });
  scene.addEventListener("wheel", (e) => {
    e.preventDefault(); view.zoom = Math.max(0.2, Math.min(40, view.zoom * (e.deltaY < 0 ? 1.15 : 1 / 1.15))); drawScene();
  }, { passive: false });
  let drag = null;
  scene.addEventListener("mousedown", (e) => { drag = [e.clientX, e.clientY]; });
  window.addEventListener("mouseup", () => { drag = null; });
  window.addEventListener("mousemove", (e) => {
    if (!drag) return;
    const s = transform().s / (window.devicePixelRatio || 1);
    view.panX -= (e.clientX - drag[0]) / s; view.panY += (e.clientY - drag[1]) / s; drag = [e.clientX, e.clientY]; drawScene();
  });
  scene.addEventListener("dblclick", () => { view.zoom = 1; view.panX = view.panY = 0; drawScene(); });

  function layout() {
    for (const p of plots) p.canvas.classList.toggle("hidden", !!p.layer && !view.layers[p.layer]);
  }
  function draw() {
    drawScene();
    for (const p of plots) drawPlot(p);
    readout();
  }
  window.addEventListener("resize", draw);
  // For scripts and tests: the cursor, the layers, what the last frame drew.
  window.hitchview = { view, setRow, setPlaying, rows: n, data: D };
  layout();
  setRow(0);
  document.body.dataset.ready = "1";
})();
