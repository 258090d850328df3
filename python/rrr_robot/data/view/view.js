/* rrr view: one run in the browser (docs/viewing.md). Reads the JSON block #run-data that
 * rrr_robot.writing.view wrote: per scenario the world pose of every URDF link at each frame
 * (computed by librrr's rrr_fk_frames, so the page does no kinematics of its own), the URDF's
 * link visuals, the pen trace, the reference and the signals. Draws the arm with a 2-D canvas in
 * an orthographic view; the body's data-* attributes give its state (frame, time, projection,
 * the strips' ranges, errors) to tests and scripts. No network: everything is in this file. */
"use strict";
(function () {
  const body = document.body;
  let errors = 0;
  function fail(message) {
    errors += 1;
    body.dataset.errors = String(errors);
    body.dataset.lastError = String(message);
  }
  window.addEventListener("error", (e) => fail(e.message));
  window.addEventListener("unhandledrejection", (e) => fail(e.reason));
  document.addEventListener("securitypolicyviolation", (e) => fail("CSP: " + e.violatedDirective));

  const data = JSON.parse(document.getElementById("run-data").textContent);
  const COLORS = data.colors;
  const scene = document.getElementById("scene");
  const slider = document.getElementById("slider");
  const timeLabel = document.getElementById("time");
  const playButton = document.getElementById("play");
  const speedSelect = document.getElementById("speed");
  const scenarioSelect = document.getElementById("scenario");
  const signalsBox = document.getElementById("signals");
  const view = { az: data.view.azimuth, el: data.view.elevation, zoom: 1.0 };
  let run = null;       // the scenario shown
  let frame = 0;
  let playing = false;
  let lastTick = 0;
  let plots = [];

  function setupCanvas(canvas, width, height) {
    const dpr = window.devicePixelRatio || 1;
    canvas.width = Math.round(width * dpr);
    canvas.height = Math.round(height * dpr);
    canvas.style.width = width + "px";
    canvas.style.height = height + "px";
    const ctx = canvas.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    return ctx;
  }
  const sceneW = 640, sceneH = 560;
  const sctx = setupCanvas(scene, sceneW, sceneH);

  // ---- projection: orthographic, turned by azimuth and elevation about the run's centre ----
  function projection() {
    const ca = Math.cos(view.az), sa = Math.sin(view.az);
    const ce = Math.cos(view.el), se = Math.sin(view.el);
    const right = [-sa, ca, 0];
    const up = [-se * ca, -se * sa, ce];
    const toward = [ce * ca, ce * sa, se];   // from the centre to the eye
    const s = 0.46 * Math.min(sceneW, sceneH) / data.view.radius * view.zoom;
    const c = data.view.center;
    const row = (v, k, off) => [k * v[0], k * v[1], k * v[2],
      off - k * (v[0] * c[0] + v[1] * c[1] + v[2] * c[2])];
    return { x: row(right, s, sceneW / 2), y: row(up, -s, sceneH / 2), depth: toward, scale: s };
  }
  function project(P, p) {
    return [P.x[0] * p[0] + P.x[1] * p[1] + P.x[2] * p[2] + P.x[3],
      P.y[0] * p[0] + P.y[1] * p[1] + P.y[2] * p[2] + P.y[3]];
  }
  const depthOf = (P, p) => P.depth[0] * p[0] + P.depth[1] * p[1] + P.depth[2] * p[2];

  function linkPose(k) {   // world rotation (row-major) and position of link k at the frame
    const a = run.links[frame], o = 12 * k;
    return { R: a.slice(o, o + 9), p: a.slice(o + 9, o + 12) };
  }
  function apply(pose, v) {
    const R = pose.R;
    return [R[0] * v[0] + R[1] * v[1] + R[2] * v[2] + pose.p[0],
      R[3] * v[0] + R[4] * v[1] + R[5] * v[2] + pose.p[1],
      R[6] * v[0] + R[7] * v[1] + R[8] * v[2] + pose.p[2]];
  }

  function polyline(ctx, P, points, count) {
    if (count < 2) return;
    ctx.beginPath();
    let q = project(P, points[0]);
    ctx.moveTo(q[0], q[1]);
    for (let i = 1; i < count; i++) {
      q = project(P, points[i]);
      ctx.lineTo(q[0], q[1]);
    }
    ctx.stroke();
  }

  function drawGround(ctx, P) {
    const g = data.view.ground, step = g.step;
    ctx.strokeStyle = COLORS.grid;
    ctx.lineWidth = 1;
    for (let v = -g.half; v <= g.half + 1e-9; v += step) {
      polyline(ctx, P, [[v, -g.half, 0], [v, g.half, 0]], 2);
      polyline(ctx, P, [[-g.half, v, 0], [g.half, v, 0]], 2);
    }
    const axes = [[COLORS.axisX, [g.step, 0, 0]], [COLORS.axisY, [0, g.step, 0]],
      [COLORS.axisZ, [0, 0, g.step]]];
    ctx.lineWidth = 2;
    for (const [color, end] of axes) {
      ctx.strokeStyle = color;
      polyline(ctx, P, [[0, 0, 0], end], 2);
    }
  }

  function drawScene() {
    const P = projection();
    const ctx = sctx;
    ctx.clearRect(0, 0, sceneW, sceneH);
    drawGround(ctx, P);
    ctx.lineJoin = "round";
    ctx.lineCap = "round";
    if (run.trace.ref) {
      ctx.strokeStyle = COLORS.ref;
      ctx.lineWidth = 1.5;
      ctx.setLineDash([5, 4]);
      polyline(ctx, P, run.trace.ref, run.trace.ref.length);
      ctx.setLineDash([]);
    }
    if (run.trace.tip) {
      const tNow = run.t[frame];
      let n = 0;
      while (n < run.trace.t.length && run.trace.t[n] <= tNow + 1e-12) n++;
      ctx.strokeStyle = COLORS.trace;
      ctx.lineWidth = 2;
      polyline(ctx, P, run.trace.tip, n);
    }
    // the URDF's cylinders, farthest first
    const parts = [];
    for (const vis of data.visuals) {
      const pose = linkPose(vis.link);
      const c = apply(pose, vis.center);
      const tip = apply({ R: pose.R, p: [0, 0, 0] }, vis.axis);
      const h = vis.length / 2;
      const a = [c[0] - h * tip[0], c[1] - h * tip[1], c[2] - h * tip[2]];
      const b = [c[0] + h * tip[0], c[1] + h * tip[1], c[2] + h * tip[2]];
      parts.push({ a: project(P, a), b: project(P, b), r: vis.radius, d: depthOf(P, c) });
    }
    parts.sort((u, v) => u.d - v.d);
    for (const part of parts) {
      const w = Math.max(3, 2 * part.r * P.scale);
      for (const [color, width] of [[COLORS.linkEdge, w + 2], [COLORS.link, w]]) {
        ctx.strokeStyle = color;
        ctx.lineWidth = width;
        ctx.beginPath();
        ctx.moveTo(part.a[0], part.a[1]);
        ctx.lineTo(part.b[0], part.b[1]);
        ctx.stroke();
      }
    }
    ctx.fillStyle = COLORS.joint;
    for (let k = 0; k < 3; k++) {
      const q = project(P, linkPose(k).p);
      ctx.beginPath();
      ctx.arc(q[0], q[1], 4, 0, 2 * Math.PI);
      ctx.fill();
    }
    const pen = project(P, linkPose(3).p);
    ctx.fillStyle = COLORS.pen;
    ctx.beginPath();
    ctx.arc(pen[0], pen[1], 3.5, 0, 2 * Math.PI);
    ctx.fill();
    const rect = scene.getBoundingClientRect();
    body.dataset.canvas = JSON.stringify([rect.left + window.scrollX, rect.top + window.scrollY]);
    body.dataset.projection = JSON.stringify([P.x, P.y]);
  }

  // ---- the signals beside the arm ----
  function makePlots() {
    signalsBox.textContent = "";
    plots = [];
    const width = Math.max(320, signalsBox.clientWidth || 520);
    const height = Math.max(90, Math.floor((sceneH - 4 * (run.signals.series.length - 1)) /
      Math.max(1, run.signals.series.length)));
    for (const series of run.signals.series) {
      const canvas = document.createElement("canvas");
      signalsBox.appendChild(canvas);
      const ctx = setupCanvas(canvas, width, height);
      let lo = Infinity, hi = -Infinity;
      for (const line of series.lines) {
        for (const v of line.values) {
          if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
        }
      }
      // a quantity that is never negative (an error norm) keeps its axis at or above 0
      const nonnegative = lo >= 0;
      if (!(hi > lo)) { lo -= 1; hi += 1; }
      const pad = 0.08 * (hi - lo);
      lo = nonnegative ? Math.max(0, lo - pad) : lo - pad;
      const plot = { canvas, ctx, width, height, series, lo, hi: hi + pad };
      canvas.addEventListener("click", (e) => {
        const r = canvas.getBoundingClientRect();
        const tt = tOfX(plot, e.clientX - r.left);
        let best = 0;
        while (best + 1 < run.t.length && run.t[best + 1] <= tt) best++;
        seek(best);
      });
      plots.push(plot);
    }
    body.dataset.ranges = JSON.stringify(plots.map((p) => [p.series.title, p.lo, p.hi]));
  }
  const left = 48;
  function xOfT(plot, t) {
    const t0 = run.signals.t[0], t1 = run.signals.t[run.signals.t.length - 1];
    return left + (plot.width - left - 8) * (t - t0) / Math.max(1e-12, t1 - t0);
  }
  function tOfX(plot, x) {
    const t0 = run.signals.t[0], t1 = run.signals.t[run.signals.t.length - 1];
    return t0 + (x - left) / (plot.width - left - 8) * (t1 - t0);
  }
  function drawPlots() {
    const ts = run.signals.t;
    for (const plot of plots) {
      const { ctx, width, height, series } = plot;
      const yOf = (v) => 16 + (height - 32) * (plot.hi - v) / (plot.hi - plot.lo);
      ctx.clearRect(0, 0, width, height);
      ctx.fillStyle = "#37474f";
      ctx.font = "12px system-ui, sans-serif";
      ctx.fillText(series.title, left, 12);
      ctx.fillStyle = "#78909c";
      ctx.fillText(plot.hi.toPrecision(3), 2, 20);
      ctx.fillText(plot.lo.toPrecision(3), 2, height - 18);
      ctx.fillText(ts[ts.length - 1].toFixed(1) + " s", width - 44, height - 4);
      let legendX = left + ctx.measureText(series.title).width + 16;
      for (const line of series.lines) {
        ctx.strokeStyle = line.color;
        ctx.lineWidth = 1.3;
        ctx.setLineDash(line.dash ? [4, 3] : []);
        ctx.beginPath();
        let pen = false;
        for (let i = 0; i < ts.length; i++) {
          const v = line.values[i];
          if (!Number.isFinite(v)) { pen = false; continue; }
          const x = xOfT(plot, ts[i]), y = yOf(v);
          if (pen) ctx.lineTo(x, y); else ctx.moveTo(x, y);
          pen = true;
        }
        ctx.stroke();
        ctx.setLineDash([]);
        ctx.fillStyle = line.color;
        ctx.fillText(line.label, legendX, 12);
        legendX += ctx.measureText(line.label).width + 12;
      }
      const x = xOfT(plot, run.t[frame]);
      ctx.strokeStyle = COLORS.cursor;
      ctx.lineWidth = 1;
      ctx.beginPath();
      ctx.moveTo(x, 14);
      ctx.lineTo(x, height - 14);
      ctx.stroke();
    }
  }

  function draw() {
    drawScene();
    drawPlots();
    const t = run.t[frame], end = run.t[run.t.length - 1];
    timeLabel.textContent = "t = " + t.toFixed(3) + " s of " + end.toFixed(3) + " s";
    body.dataset.frame = String(frame);
    body.dataset.time = String(t);
    body.dataset.scenario = run.name;
  }
  function seek(k) {
    frame = Math.max(0, Math.min(run.t.length - 1, k | 0));
    if (Number(slider.value) !== frame) slider.value = String(frame);
    draw();
  }
  function show(index) {
    run = data.scenarios[index];
    scenarioSelect.value = String(index);
    slider.max = String(run.t.length - 1);
    makePlots();
    seek(Math.min(frame, run.t.length - 1));
  }

  // ---- controls ----
  slider.addEventListener("input", () => seek(Number(slider.value)));
  scenarioSelect.addEventListener("change", () => show(Number(scenarioSelect.value)));
  function tick(now) {
    if (!playing) return;
    const dt = (now - lastTick) / 1000 * Number(speedSelect.value);
    lastTick = now;
    const target = run.t[frame] + dt;
    let k = frame;
    while (k + 1 < run.t.length && run.t[k + 1] <= target) k++;
    if (k === run.t.length - 1) {
      playing = false;
      playButton.textContent = "play";
    }
    seek(k);
    if (playing) window.requestAnimationFrame(tick);
  }
  function togglePlay() {
    playing = !playing;
    playButton.textContent = playing ? "pause" : "play";
    if (playing) {
      if (frame === run.t.length - 1) seek(0);
      lastTick = performance.now();
      window.requestAnimationFrame(tick);
    }
  }
  playButton.addEventListener("click", togglePlay);
  document.getElementById("reset").addEventListener("click", () => {
    view.az = data.view.azimuth; view.el = data.view.elevation; view.zoom = 1.0; draw();
  });
  document.addEventListener("keydown", (e) => {
    if (e.target === scenarioSelect || e.target === speedSelect) return;
    if (e.key === " ") { e.preventDefault(); togglePlay(); }
    else if (e.key === "ArrowRight" && e.target !== slider) seek(frame + 1);
    else if (e.key === "ArrowLeft" && e.target !== slider) seek(frame - 1);
    else if (e.key === "r" || e.key === "R") document.getElementById("reset").click();
  });
  let drag = null;
  scene.addEventListener("pointerdown", (e) => {
    drag = { x: e.clientX, y: e.clientY, az: view.az, el: view.el };
    scene.setPointerCapture(e.pointerId);
  });
  scene.addEventListener("pointermove", (e) => {
    if (!drag) return;
    view.az = drag.az - (e.clientX - drag.x) * 0.01;
    view.el = Math.max(-1.55, Math.min(1.55, drag.el + (e.clientY - drag.y) * 0.01));
    drawScene();
  });
  scene.addEventListener("pointerup", () => { drag = null; });
  scene.addEventListener("wheel", (e) => {
    e.preventDefault();
    view.zoom = Math.max(0.2, Math.min(8, view.zoom * Math.exp(-e.deltaY * 0.001)));
    drawScene();
  }, { passive: false });

  data.scenarios.forEach((s, i) => {
    const option = document.createElement("option");
    option.value = String(i);
    option.textContent = s.name;
    scenarioSelect.appendChild(option);
  });
  // #scenario=NAME&t=SECONDS picks what is shown first (through the slider, as a user would)
  const params = new URLSearchParams(window.location.hash.slice(1));
  const wanted = data.scenarios.findIndex((s) => s.name === params.get("scenario"));
  show(Math.max(0, wanted));
  if (params.has("t")) {
    const tt = Number(params.get("t"));
    let k = 0;
    while (k + 1 < run.t.length && Math.abs(run.t[k + 1] - tt) <= Math.abs(run.t[k] - tt)) k++;
    slider.value = String(k);
    slider.dispatchEvent(new Event("input"));
  }
  body.dataset.state = "ready";
})();
