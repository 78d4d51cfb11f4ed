// hitchpark drive: the live page of the knob assist. The server ticks the car at the plant's rate over a
// WebSocket; this page sends the knob and the speed key, and draws each tick: the rig among the scene, the
// curvature asked against the one got, the hitch against its limit, each override as it happens.
(function () {
  "use strict";
  const { esc } = hitchpark;
  const D = JSON.parse(document.getElementById("hitchpark-data").textContent);
  const app = document.getElementById("app");
  app.innerHTML = `
    <header><h1>${esc(D.title)}</h1><span id="status">connecting</span></header>
    <div style="display:flex;flex-direction:row;gap:12px;padding:10px;align-items:flex-start">
      <canvas id="scene" width="640" height="520" style="border:1px solid var(--line);background:#fff"></canvas>
      <section style="min-width:300px">
        <p><b>Knob</b> (wheel or drag on it, ← →; C centres): <span id="knob-value">0.00</span></p>
        <div id="knob" style="width:280px;height:36px;border:1px solid var(--line);position:relative;cursor:ew-resize;background:var(--panel)">
          <div id="knob-mark" style="position:absolute;top:0;bottom:0;width:4px;background:#1f5fa8;left:138px"></div>
        </div>
        <p><b>Speed</b>: hold ↑ (or W) to back up at <span id="speed-max"></span> m/s; Esc stops the car.
          <br>asked <span id="speed-request">0.00</span> m/s, driving <span id="speed">0.00</span> m/s</p>
        <p><b>Trailer curvature</b> [1/m]: asked <span id="curv-asked">0</span>, followed <span id="curv-cmd">0</span>,
          got <span id="curv-got">-</span></p>
        <svg id="curv" width="280" height="40"></svg>
        <p><b>Hitch</b>: <span id="hitch">0.0</span>° (limit ±<span id="hitch-limit"></span>°)</p>
        <svg id="gauge" width="280" height="150"></svg>
        <p><b>Override</b>: <span id="override">none</span></p>
        <ol id="overrides" style="max-height:150px;overflow:auto;margin:0;padding-left:20px"></ol>
        <p id="saved"></p>
      </section>
    </div>`;
  const $ = (id) => document.getElementById(id);
  $("speed-max").textContent = D.max_speed.toFixed(1);
  $("hitch-limit").textContent = D.max_hitch_deg.toFixed(0);
  const state = { knob: 0, speedKey: false, last: null, overridesSeen: [], maxAbsHitch: 0, ticks: 0, trail: [], done: null, saved: null, stopSentAt: null };
  window.hitchDrive = state;

  const ws = new WebSocket(`ws://${location.host}/ws`);
  const send = () => { if (ws.readyState === 1) ws.send(JSON.stringify({ knob: state.knob, speed: state.speedKey ? D.max_speed : 0 })); };
  const setKnob = (k) => { state.knob = Math.max(-1, Math.min(1, Math.round(k * 100) / 100)); showKnob(); send(); };
  function showKnob() {
    $("knob-value").textContent = state.knob.toFixed(2);
    $("knob-mark").style.left = `${138 - state.knob * 138}px`;  // left on the page is a left knob (k > 0)
  }
  ws.onopen = () => { $("status").textContent = "driving: turn the knob, hold ↑"; send(); };
  ws.onclose = () => { if (!state.done) $("status").textContent = "disconnected"; };
  ws.onmessage = (ev) => {
    const m = JSON.parse(ev.data);
    if (m.saved) { state.saved = m.saved; $("saved").textContent = `saved: ${m.saved}`; return; }
    state.last = m; state.ticks += 1;
    state.maxAbsHitch = Math.max(state.maxAbsHitch, Math.abs(m.hitch_deg));
    state.trail.push([m.state[0], m.state[1]]);
    if (m.override && m.override !== "none") {
      const prev = state.overridesSeen[state.overridesSeen.length - 1];
      if (!prev || prev.override !== m.override || m.t - prev.until > 0.15) {
        state.overridesSeen.push({ override: m.override, t: m.t, until: m.t });
        const li = document.createElement("li");
        li.textContent = `t = ${m.t.toFixed(1)} s: ${m.override.replace(/_/g, " ")}`;
        $("overrides").appendChild(li);
        $("overrides").scrollTop = $("overrides").scrollHeight;
      } else prev.until = m.t;
    }
    if (m.done) { state.done = m.done; $("status").textContent = `ended: ${m.done.replace(/_/g, " ")}`; }
    else if (m.stopping) $("status").textContent = "stopping (Esc)";
    draw(m);
  };

  // The knob: the mouse wheel, a drag across it, the arrow keys.
  $("knob").addEventListener("wheel", (e) => { e.preventDefault(); setKnob(state.knob + (e.deltaY < 0 ? 0.05 : -0.05)); }, { passive: false });
  let dragging = false;
  const fromMouse = (e) => { const r = $("knob").getBoundingClientRect(); setKnob(1 - 2 * (e.clientX - r.left) / r.width); };
  $("knob").addEventListener("mousedown", (e) => { dragging = true; fromMouse(e); });
  window.addEventListener("mousemove", (e) => { if (dragging) fromMouse(e); });
  window.addEventListener("mouseup", () => { dragging = false; });
  window.addEventListener("keydown", (e) => {
    if (e.key === "ArrowLeft") setKnob(state.knob + 0.1);
    else if (e.key === "ArrowRight") setKnob(state.knob - 0.1);
    else if (e.key === "c" || e.key === "C") setKnob(0);
    else if ((e.key === "ArrowUp" || e.key === "w" || e.key === "W") && !state.speedKey) { state.speedKey = true; send(); }
    else if (e.key === "Escape") { state.stopSentAt = state.ticks; if (ws.readyState === 1) ws.send(JSON.stringify({ stop: true })); }
    else return;
    e.preventDefault();
  });
  window.addEventListener("keyup", (e) => {
    if ((e.key === "ArrowUp" || e.key === "w" || e.key === "W") && state.speedKey) { state.speedKey = false; send(); }
  });

  // Drawing: the world frame fitted to the canvas (the scene's bounds and the start), y up.
  const cv = $("scene"), g = cv.getContext("2d");
  const pts = [...D.bounds];
  const [x0, y0, x1, y1] = [Math.min(...pts.map(p => p[0])) - 4, Math.min(...pts.map(p => p[1])) - 4, Math.max(...pts.map(p => p[0])) + 4, Math.max(...pts.map(p => p[1])) + 4];
  const s = Math.min(cv.width / (x1 - x0), cv.height / (y1 - y0));
  const P = (p) => [(p[0] - x0) * s, cv.height - (p[1] - y0) * s];
  function poly(points, fill, stroke) {
    g.beginPath(); points.forEach((p, i) => { const [u, v] = P(p); i ? g.lineTo(u, v) : g.moveTo(u, v); }); g.closePath();
    if (fill) { g.fillStyle = fill; g.fill(); } if (stroke) { g.strokeStyle = stroke; g.stroke(); }
  }
  function draw(m) {
    g.clearRect(0, 0, cv.width, cv.height);
    if (D.area) poly(D.area, null, "#999");
    D.obstacles.forEach((o) => poly(o, "#c9c2b8", "#8a8178"));
    const gl = D.goal, c = Math.cos(gl.yaw), sn = Math.sin(gl.yaw);
    poly([[-1, -0.9], [3, -0.9], [3, 0.9], [-1, 0.9]].map(([a, b]) => [gl.x + c * a - sn * b, gl.y + sn * a + c * b]), null, "#1b7f3b");
    g.strokeStyle = "#1f5fa8"; g.beginPath(); state.trail.forEach((p, i) => { const [u, v] = P(p); i ? g.lineTo(u, v) : g.moveTo(u, v); }); g.stroke();
    poly(m.trailer, "rgba(230,140,40,0.55)", "#a35a00");
    poly(m.vehicle, "rgba(31,95,168,0.55)", "#1f3f6f");
    $("hitch").textContent = m.hitch_deg.toFixed(1);
    $("speed").textContent = Math.abs(m.speed).toFixed(2);
    if (m.override !== undefined) {
      $("override").textContent = m.override.replace(/_/g, " ");
      $("override").style.color = m.override === "none" ? "" : "var(--bad)";
      $("speed-request").textContent = m.speed_request.toFixed(2);
      $("curv-asked").textContent = m.curvature_asked.toFixed(3);
      $("curv-cmd").textContent = m.curvature_cmd.toFixed(3);
    }
    $("curv-got").textContent = m.curvature === null ? "-" : m.curvature.toFixed(3);
    const bar = (k) => 140 - 130 * Math.max(-1.2, Math.min(1.2, k / D.kappa_max)) / 1.2;
    const asked = m.curvature_asked ?? 0, got = m.curvature ?? 0;
    $("curv").innerHTML = `<line x1="140" y1="0" x2="140" y2="40" stroke="#999"/>
      <rect x="${Math.min(140, bar(asked))}" y="4" width="${Math.abs(bar(asked) - 140)}" height="14" fill="#1f5fa8"/>
      <rect x="${Math.min(140, bar(got))}" y="22" width="${Math.abs(bar(got) - 140)}" height="14" fill="#e08c28"/>`;
    const needle = (deg, len, col, w) => { const a = Math.PI / 2 + deg * Math.PI / 180; return `<line x1="140" y1="140" x2="${140 + len * Math.cos(a)}" y2="${140 - len * Math.sin(a)}" stroke="${col}" stroke-width="${w}"/>`; };
    $("gauge").innerHTML = `<path d="M 20 140 A 120 120 0 0 1 260 140" fill="none" stroke="#ccc" stroke-width="8"/>`
      + needle(D.max_hitch_deg, 125, "var(--bad)", 3) + needle(-D.max_hitch_deg, 125, "var(--bad)", 3)
      + needle(m.hitch_deg, 110, "#1a1a1a", 4);
  }
  showKnob();
})();
