// exoleg operator interface. Angles and torques arrive in SI units (rad, N m); the page
// shows degrees where people read. The loop runs in another process: nothing here can
// slow it. The E-stop is sent without a token, from any page, by anyone: its button lies
// above every dialog and banner, and its key (F2) is one nobody presses by habit (Esc
// cancels a question).
"use strict";

// The names of modes, phases, events and safety bits come from the server (/api/info:
// vocabulary, taken from the enumerations the compiled tick uses), as do the gains.
const VOC = () => (S.info && S.info.vocabulary) || {Mode: {}, text: {Phase: {}, Event: [], Limited: []}};
const MODE = (m) => VOC().Mode[m] || String(m);
const JOINTS = ["hip", "knee", "ankle"];
const GAINS = () => (S.info && S.info.gains) || [];
const WINDOW = 5.0;  // s of history on the charts
const DEG = 180 / Math.PI;

const S = {
  token: "", operator: sessionStorage.getItem("exoleg-operator") || "",
  info: null, state: null, hist: [], events: [], updates: [], lastMode: null,
  lastMsg: 0, lastEvent: -1, eventCount: 0, estopFailed: false, estopPending: 0, startPending: false,
  historyOf: null, drawnMsg: 0, drawnAt: -Infinity,
};
const ESTOP_KEY = "F2";
const ESTOP_WAIT_MS = 300;  // an E-stop unanswered this long: said at once, and sent again
const ESTOP_RETRY_S = 10;  // ... for this long
const STALE_MS = 1000;  // no update for this long: the page says the link is lost
// The page is drawn when the stream brought something new, at most every DRAW_MS (the
// stream comes at 50 Hz), and every IDLE_DRAW_MS without it, so a silent link is said
// within that of STALE_MS. Drawn on every animation frame (60 Hz), a headless Chromium
// spent 0.68 of a core on this page while the device walked and 0.23 with no session;
// drawn so, 0.27 and 0.12.
const DRAW_MS = 40;
const IDLE_DRAW_MS = 100;

// ---------------------------------------------------------------- plumbing
const $ = (id) => document.getElementById(id);
const esc = (x) => String(x).replace(/[&<>"']/g, (c) => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"}[c]));

function say(text, ok) {
  const m = $("message");
  m.textContent = text;
  m.className = ok ? "ok" : "error";
}

function authHeaders() {
  const headers = {"Content-Type": "application/json"};
  if (S.token) headers["Authorization"] = "Bearer " + S.token;
  if (S.operator) headers["X-Operator"] = S.operator;
  return headers;
}

async function call(method, url, body) {
  const headers = authHeaders();
  let r;
  try {
    r = await fetch(url, {method, headers, body: body === undefined ? undefined : JSON.stringify(body)});
  } catch (e) {
    return {ok: false, status: 0, data: {error: "the server does not answer: " + e}};
  }
  let data = {};
  try { data = await r.json(); } catch (e) { data = {}; }
  return {ok: r.ok, status: r.status, data};
}

async function act(method, url, body, done) {
  const r = await call(method, url, body);
  if (r.ok && r.data.applied === null) say((done || "done") + "; the loop has not answered yet", true);
  else if (r.ok) say(done || "done", true);
  else if (r.data.applied === false) say("refused by the supervisor: " + r.data.error, false);
  else if (r.status === 0) say("not sent: " + r.data.error, false);
  else say("refused: " + (r.data.error || r.status), false);
  return r;
}

// a question before an action that takes the torque off or ends a session while moving:
// not modal (a modal dialog makes the rest of the page inert, the E-stop with it); its
// backdrop covers the page under the E-stop; Esc or "No" goes back
let closeQuestion = null;
function confirmFirst(text) {
  const d = $("confirm");
  $("confirm-text").textContent = text;
  return new Promise((done) => {
    const end = (yes) => {
      closeQuestion = null; d.close(); $("backdrop").hidden = true;
      $("confirm-yes").onclick = $("confirm-no").onclick = $("backdrop").onclick = null;
      done(yes);
    };
    closeQuestion = () => end(false);
    $("confirm-yes").onclick = () => end(true);
    $("confirm-no").onclick = () => end(false);
    $("backdrop").onclick = () => end(false);
    $("backdrop").hidden = false;
    d.show();
    $("confirm-no").focus();
  });
}

// ---------------------------------------------------------------- E-stop: always there
function estopUnreachable(why, since) {
  if (!S.estopFailed) window.estopUnreachableMs = performance.now() - since;  // for the tests
  S.estopFailed = true;
  $("estop").classList.add("unreachable");
  say("E-STOP DID NOT REACH THE DEVICE (" + why + "). Use the hardware E-stop now.", false);
}

async function estop(ev) {
  // the press on the system's wall clock (the one the server reads): now, less the time
  // since the event on the page's monotonic clock (performance.timeOrigin + timeStamp
  // drifts from the wall clock by tens of ms over minutes)
  const clicked = Date.now() - (ev && ev.timeStamp ? performance.now() - ev.timeStamp : 0);
  window.lastEstopClick = clicked;
  if (closeQuestion) closeQuestion();  // a question asked before the E-stop no longer stands
  const id = ++S.estopPending, since = performance.now();
  // timed on the page's own clock, for benchmarks/bench_hmi.py: from the press to this
  // handler, and from it to the server's answer (the E-stop queued for the loop)
  window.estopTrace = {handler_ms: ev && ev.timeStamp ? since - ev.timeStamp : 0};
  S.estopFailed = false;
  // the page already knows it cannot see the server: said at once, sent all the same
  if (!linkFresh()) estopUnreachable("this page has had no update from the server for " +
    (S.lastMsg ? ((performance.now() - S.lastMsg) / 1000).toFixed(1) + " s" : "ever"), since);
  else say("E-STOP sent...", true);
  const until = performance.now() + ESTOP_RETRY_S * 1000;
  for (let n = 0; id === S.estopPending && performance.now() < until; n++) {
    const ctl = new AbortController();
    const timer = setTimeout(() => ctl.abort(), ESTOP_WAIT_MS);
    let r = null;
    try {
      r = await fetch("/api/estop", {method: "POST", signal: ctl.signal, headers: authHeaders(),
        body: JSON.stringify({clicked_at: clicked})});  // each try: the one that arrives is timed from the press
    } catch (e) {
      r = null;  // no answer within ESTOP_WAIT_MS, or no connection
    }
    clearTimeout(timer);
    window.estopTrace.answered_ms = performance.now() - since;
    if (r && r.ok) {
      S.estopFailed = false;
      $("estop").classList.remove("unreachable");
      say("E-STOP reached the device: torque off" + (n ? ` (sent ${n + 1} times: the server answered late)` : ""), true);
      return;
    }
    if (r) {  // answered, but not queued: no session is running
      const data = await r.json().catch(() => ({}));
      say("E-STOP: " + (data.error || r.status), false);
      return;
    }
    estopUnreachable(`the server has not answered within ${ESTOP_WAIT_MS} ms; still sending it`, since);
    await new Promise((ok) => setTimeout(ok, 200));
  }
}
// on the press, not the release (a click fires when the button is let go: tens of ms
// later for a hand, more for a finger); the click that follows a press is the same stop
let pressedAt = -1e9;
$("estop").addEventListener("pointerdown", (e) => { pressedAt = performance.now(); estop(e); });
$("estop").addEventListener("click", (e) => { if (performance.now() - pressedAt > 1000) estop(e); });
document.addEventListener("keydown", (e) => {
  if (e.key === ESTOP_KEY) { e.preventDefault(); estop(e); }
  else if (e.key === "Escape" && closeQuestion) { e.preventDefault(); closeQuestion(); }
});

// ---------------------------------------------------------------- pages
function show() {
  const page = (location.hash || "#live").slice(1);
  for (const p of ["child", "live", "control", "sessions"]) {
    $("page-" + p).classList.toggle("shown", p === page);
    $("nav-" + p).classList.toggle("active", p === page);
  }
  if (page === "sessions") loadSessions();
  if (page === "control") loadGains();
}
window.addEventListener("hashchange", show);

// ---------------------------------------------------------------- state stream
function connect() {
  const ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/api/stream");
  ws.onmessage = (m) => {
    const s = JSON.parse(m.data);
    const now = performance.now();
    S.lastMsg = now;
    S.updates.push(now);
    while (S.updates.length && S.updates[0] < now - 2000) S.updates.shift();
    if (s.running === undefined || s.running === "none" || s.tick === undefined) { S.state = s; return; }
    const last = S.hist.length ? S.hist[S.hist.length - 1] : null;
    if (!last || s.t !== last.t) {
      if (last && s.t < last.t) { S.hist = []; S.lastEvent = -1; }
      S.hist.push(s);
      while (S.hist.length && S.hist[0].t < s.t - WINDOW) S.hist.shift();
      // every gait event the loop saw (its ring, numbered), not only those of this update
      for (const [i, t, bits] of s.event_log || []) {
        if (i <= S.lastEvent) continue;
        S.lastEvent = i;
        for (const [bit, name] of VOC().text.Event) if (bits & bit) { S.events.unshift(`${t.toFixed(2)} s: ${name}`); S.eventCount += 1; }
      }
      if (S.lastMode !== null && s.mode !== S.lastMode) S.events.unshift(`${s.t.toFixed(2)} s: ${MODE(S.lastMode)} -> ${MODE(s.mode)}`);
      S.lastMode = s.mode;
      S.events.length = Math.min(S.events.length, 16);
    }
    S.state = s;
  };
  ws.onclose = () => setTimeout(connect, 500);
}

// ---------------------------------------------------------------- drawing
function legPoints(q, lengths, offsets) {
  // the same chain as exoleg.kinematics.forward_kinematics: phi_i = sum (q_k + offset_k)
  const pts = [[0, 0]];
  let phi = 0;
  for (let i = 0; i < 3; i++) {
    phi += q[i] + offsets[i];
    const [x, y] = pts[i];
    pts.push([x + lengths[i] * Math.cos(phi), y + lengths[i] * Math.sin(phi)]);
  }
  return pts;  // hip, knee, ankle, toe (m; x forward, y up)
}
window.legPoints = legPoints;

function drawLeg(s) {
  const c = $("leg"), g = c.getContext("2d"), d = S.info.device;
  const reach = d.lengths.reduce((a, b) => a + b, 0);
  const k = c.height / (1.25 * reach), ox = c.width / 2, oy = 0.12 * c.height;
  const px = (p) => [ox + k * p[0], oy - k * p[1]];
  g.clearRect(0, 0, c.width, c.height);
  g.strokeStyle = "#ddd"; g.beginPath(); g.moveTo(0, oy + k * (reach * 0.98)); g.lineTo(c.width, oy + k * (reach * 0.98)); g.stroke();
  const chain = (q, color, width, dash) => {
    const p = legPoints(q, d.lengths, d.offsets).map(px);
    g.setLineDash(dash); g.strokeStyle = color; g.lineWidth = width; g.lineCap = "round";
    g.beginPath(); g.moveTo(...p[0]); for (const x of p.slice(1)) g.lineTo(...x); g.stroke();
    g.setLineDash([]);
    return p;
  };
  chain(s.q_ref, "#999", 2, [6, 4]);
  const p = chain(s.q, "#e67e22", 8, []);
  g.fillStyle = "#1565c0";
  for (const x of p.slice(0, 3)) { g.beginPath(); g.arc(x[0], x[1], 6, 0, 2 * Math.PI); g.fill(); }
}

function axes(g, x0, y0, w, h, ylo, yhi, title) {
  g.strokeStyle = "#bbb"; g.lineWidth = 1; g.strokeRect(x0, y0, w, h);
  g.fillStyle = "#333"; g.font = "11px sans-serif";
  g.fillText(title, x0 + 4, y0 + 12);
  g.fillText(yhi.toFixed(0), x0 - 28, y0 + 10); g.fillText(ylo.toFixed(0), x0 - 28, y0 + h);
  return (v) => y0 + h - (v - ylo) / (yhi - ylo) * h;
}

function drawAngles() {
  const c = $("angles"), g = c.getContext("2d"), d = S.info.device;
  g.clearRect(0, 0, c.width, c.height);
  if (!S.hist.length) return;
  const tEnd = S.hist[S.hist.length - 1].t, h = 95, x0 = 34, w = c.width - 44;
  const X = (t) => x0 + (t - (tEnd - WINDOW)) / WINDOW * w;
  JOINTS.forEach((j, i) => {
    const lo = d.rom_lower[i] * DEG - 5, hi = d.rom_upper[i] * DEG + 5, y0 = 6 + i * (h + 12);
    const Y = axes(g, x0, y0, w, h, lo, hi, j);
    g.strokeStyle = "#ef9a9a"; g.setLineDash([3, 3]);
    for (const v of [d.rom_lower[i] * DEG, d.rom_upper[i] * DEG]) { g.beginPath(); g.moveTo(x0, Y(v)); g.lineTo(x0 + w, Y(v)); g.stroke(); }
    g.setLineDash([]);
    for (const [key, color, dash] of [["q_ref", "#888", [6, 4]], ["q", "#e67e22", []]]) {
      g.strokeStyle = color; g.lineWidth = 1.6; g.setLineDash(dash); g.beginPath();
      S.hist.forEach((s, n) => { const y = Y(s[key][i] * DEG); n ? g.lineTo(X(s.t), y) : g.moveTo(X(s.t), y); });
      g.stroke(); g.setLineDash([]);
    }
  });
}

function drawTorques(s) {
  const c = $("torques"), g = c.getContext("2d"), acts = S.info.device.actuators;
  g.clearRect(0, 0, c.width, c.height);
  const gap = 40, w = (c.width - 3 * gap) / 3 - 4, h = c.height - 30;
  acts.forEach((a, i) => {
    const x0 = gap + i * (w + gap), y0 = 6;
    const wmax = a.envelope_speed[a.envelope_speed.length - 1] * DEG, tmax = a.torque_limit * 1.15;
    const X = (v) => x0 + (v + wmax) / (2 * wmax) * w, Y = axes(g, x0, y0, w, h, -tmax, tmax, a.joint);
    g.fillStyle = "rgba(120,144,156,0.18)"; g.beginPath();
    a.envelope_speed.forEach((v, n) => { const p = [X(v * DEG), Y(a.envelope_torque[n])]; n ? g.lineTo(...p) : g.moveTo(...p); });
    for (let n = a.envelope_speed.length - 1; n >= 0; n--) g.lineTo(X(-a.envelope_speed[n] * DEG), Y(a.envelope_torque[n]));
    for (let n = 0; n < a.envelope_speed.length; n++) g.lineTo(X(-a.envelope_speed[n] * DEG), Y(-a.envelope_torque[n]));
    for (let n = a.envelope_speed.length - 1; n >= 0; n--) g.lineTo(X(a.envelope_speed[n] * DEG), Y(-a.envelope_torque[n]));
    g.fill();
    g.fillStyle = "#90a4ae";
    for (const h0 of S.hist.slice(-50)) g.fillRect(X(h0.dq[i] * DEG) - 1, Y(h0.tau[i]) - 1, 2, 2);
    g.fillStyle = "#c62828"; g.beginPath(); g.arc(X(s.dq[i] * DEG), Y(s.tau[i]), 4, 0, 2 * Math.PI); g.fill();
    g.fillStyle = "#333"; g.fillText("speed (deg/s)", x0 + w / 2 - 30, y0 + h + 14);
  });
  $("torque-table").innerHTML = "<tr><th></th>" + JOINTS.map((j) => `<th>${j}</th>`).join("") + "</tr>" +
    "<tr><td>torque (N m)</td>" + s.tau.map((x) => `<td>${x.toFixed(1)}</td>`).join("") + "</tr>" +
    "<tr><td>peak limit (N m)</td>" + acts.map((a) => `<td>${a.torque_limit.toFixed(0)}</td>`).join("") + "</tr>" +
    "<tr><td>continuous (N m)</td>" + acts.map((a) => `<td>${a.continuous_torque.toFixed(0)}</td>`).join("") + "</tr>";
}

// the foot board's counts as newtons: the board's response inverted on the server
// (FootSensors.newtons, /api/info), interpolated between its grid's points
function newtons(counts) {
  const xs = S.info.device.fsr_counts, ys = S.info.device.fsr_newtons;
  let i = 1;
  while (i < xs.length - 1 && xs[i] < counts) i++;
  const a = xs[i - 1], b = xs[i];
  return ys[i - 1] + (ys[i] - ys[i - 1]) * Math.max(0, Math.min(1, (counts - a) / ((b - a) || 1)));
}

// the load on the foot sensors in % of the child's body weight (g = 9.81 m/s^2)
function footLoad(s) {
  if (!s.body_mass) return null;
  return 100 * s.fsr.reduce((sum, c) => sum + newtons(c), 0) / (s.body_mass * 9.81);
}

function drawFsr(s) {
  const c = $("fsr"), g = c.getContext("2d"), d = S.info.device;
  g.clearRect(0, 0, c.width, c.height);
  const xs = d.sensor_x, lo = Math.min(...xs) - 0.03, hi = Math.max(...xs) + 0.04;
  const X = (x) => 20 + (x - lo) / (hi - lo) * (c.width - 40);
  g.fillStyle = "#eceff1"; g.beginPath(); g.ellipse(c.width / 2, 75, c.width / 2 - 10, 40, 0, 0, 2 * Math.PI); g.fill();
  xs.forEach((x, i) => {
    const v = Math.max(0, Math.min(1, s.fsr[i] / 4095));
    g.fillStyle = `rgb(${Math.round(255 * v)},${Math.round(120 * (1 - v))},${Math.round(200 * (1 - v))})`;
    g.beginPath(); g.arc(X(x), 75, 8 + 16 * v, 0, 2 * Math.PI); g.fill();
    g.fillStyle = "#333"; g.font = "11px sans-serif"; g.fillText(`${d.sensors[i]} ${s.fsr[i].toFixed(0)}`, X(x) - 22, 128 + 14 * (i % 2));
  });
}

function banner(id, text) {
  const b = $(id);
  if (b.textContent !== text) b.textContent = text;
  b.hidden = !text;
}

const linkFresh = () => S.lastMsg > 0 && performance.now() - S.lastMsg <= STALE_MS;

function linkState(s) {
  // the stream's age on this page, then the loop's behind the server
  const age = S.lastMsg ? (performance.now() - S.lastMsg) / 1000 : Infinity;
  if (!linkFresh()) {
    $("hdr-link").textContent = S.lastMsg ? `link: LOST (${age.toFixed(1)} s)` : "link: connecting";
    $("hdr-link").className = "link lost";
    banner("link-lost", S.lastMsg ? `No update from the server for ${age.toFixed(1)} s: this page cannot see the device, ` +
      "and its E-stop may not reach it. Use the hardware E-stop if the child needs it; check that exoleg still runs, then reload this page." : "");
    return false;
  }
  const silent = s && s.running === "running" && s.loop_age_s > STALE_MS / 1000;
  $("hdr-link").textContent = silent ? `link: loop silent ${s.loop_age_s.toFixed(1)} s` : "link: live";
  $("hdr-link").className = "link" + (silent ? " lost" : "");
  banner("link-lost", silent ? `The server answers but the device's loop has not published for ${s.loop_age_s.toFixed(1)} s. ` +
    "Use the hardware E-stop if the child needs it." : "");
  return !silent;
}

// the buttons a mode allows (the supervisor's own table, from the server)
function enableButtons(s) {
  const running = s && s.running === "running";
  const applies = running ? [...((VOC().applies || {})[String(s.mode)] || []),
    ...((VOC().support_applies || []).includes(MODE(s.mode)) ? VOC().support_commands || [] : [])] : [];
  for (const b of document.querySelectorAll("[data-command]")) b.disabled = !applies.includes(b.dataset.command);
  const live = s && (s.running === "running" || s.running === "starting");
  // a start in flight: a second tap would be refused as another session
  $("start").disabled = !!live || S.startPending || (S.info && S.info.fixed);
  $("identify").disabled = !!live || S.startPending || (S.info && S.info.fixed);
  $("end").disabled = !live;
}

// how the last session ended, kept on every page until this page's operator acknowledges
// it (per session, for this tab); the banner says it in the session's own words
const acknowledged = () => JSON.parse(sessionStorage.getItem("exoleg-acknowledged") || "[]");
function endedBanner(s) {
  const e = s && s.ended;
  const show = e && !acknowledged().includes(e.session + "@" + e.time);
  banner("ended-text", show ? `Session ${e.session} ended at ${new Date(e.time * 1000).toLocaleTimeString()} ` +
    `(${e.t.toFixed(1)} s in, last ${e.mode}): ${e.stopped_by}` + (e.fault_text ? `. Fault: ${e.fault_text.split(" To go on:")[0]}` : "") : "");
  $("ended-banner").hidden = !show;
  $("ended-banner").dataset.key = show ? e.session + "@" + e.time : "";
}
$("ended-ack").onclick = () => {
  const key = $("ended-banner").dataset.key;
  if (key) sessionStorage.setItem("exoleg-acknowledged", JSON.stringify([...acknowledged(), key].slice(-50)));
  $("ended-banner").hidden = true;
};

function clearLive() {
  // no session ticking: nothing of an old frame stays drawn as if it were now
  for (const id of ["leg", "angles", "torques", "fsr"]) { const c = $(id); c.getContext("2d").clearRect(0, 0, c.width, c.height); }
  for (const id of ["t-session", "t-remaining", "steps", "support", "phase", "foot-load", "gait-source", "safety", "windings",
    "interaction", "support-level", "t", "late", "late-max", "missed"]) $(id).textContent = "-";
  for (const id of ["fault-live", "torque-table", "cuffs", "cuff-rule", "events"]) $(id).innerHTML = "";
}

const clock = (x) => `${Math.floor(x / 60)}:${String(Math.floor(x % 60)).padStart(2, "0")}`;

// the cuffs' torque per kg of the child's body mass as the safety layer judges it (the
// reading through the cuffs' low-pass), against the limit it enforces (the device's
// safety.toml [cuffs], from /api/info): beyond it the support falls, beyond it for
// longer a controlled stop, beyond cuff_off_at x it torque off
function drawCuffs(s) {
  const D = S.info.device, lim = D.cuff_limit_Nm_per_kg, m = s.body_mass;
  if (s.interaction.every((v) => v === null) || !m) { $("cuffs").innerHTML = ""; return false; }
  const per = s.cuff.map((v) => v === null ? null : Math.abs(v) / m);
  const over = per.map((v, i) => v !== null && lim[i] !== null && v > lim[i]);
  const cell = (v, i) => `<td class="${over[i] ? "over" : ""}">${v === null ? "-" : v.toFixed(2)}</td>`;
  $("cuffs").innerHTML = "<tr><th></th>" + JOINTS.map((j) => `<th>${j}</th>`).join("") + "</tr>" +
    "<tr><td>N m/kg now</td>" + per.map(cell).join("") + "</tr>" +
    "<tr><td>limit (N m/kg)</td>" + lim.map((v) => `<td>${v === null ? "not watched" : v.toFixed(1)}</td>`).join("") + "</tr>" +
    "<tr><td>share of the limit</td>" + per.map((v, i) => `<td class="${over[i] ? "over" : ""}">${v === null || lim[i] === null ? "-" : (100 * v / lim[i]).toFixed(0) + " %"}</td>`).join("") + "</tr>";
  $("cuff-rule").textContent = `beyond the limit the support falls; beyond it for ${D.cuff_stop_after_s} s a ` +
    `controlled stop; beyond ${D.cuff_off_at} x the limit torque off`;
  return true;
}

function frame(now) {
  requestAnimationFrame(frame);
  const news = S.lastMsg !== S.drawnMsg;
  if (now - S.drawnAt < (news ? DRAW_MS : IDLE_DRAW_MS)) return;
  S.drawnAt = now;
  S.drawnMsg = S.lastMsg;
  draw();
}

function draw() {
  const s = S.state;
  const fresh = linkState(s);
  if (s && S.info) {
    const running = s.running === "running";  // ticking (not starting, not ended)
    const known = s.running && s.running !== "none";
    const ended = s.running === "ended";
    $("hdr-session").textContent = known ? `session ${S.info.session || ""}: ${s.running}` : "no session";
    // the mode the loop is in, and only while it ticks and this page sees it now
    const mode = !fresh || !known ? "-" : ended ? "ENDED (torque off)" : running ? MODE(s.mode) : "-";
    for (const id of ["hdr-mode", "mode", "ctl-mode"]) $(id).textContent = mode;
    const support = fresh && running
      ? ((VOC().SupportMode || {})[String(s.support_mode)] || "-").toLowerCase() : "-";
    for (const id of ["support-mode", "ctl-support"]) $(id).textContent = support;
    $("hdr-mode").className = "mode" + (running && fresh ? " m" + s.mode : "");
    $("rate").textContent = (S.updates.length / 2).toFixed(0) + " per s";
    banner("alarm", s.alarm ? `ALARM ${new Date(s.alarm.time * 1000).toLocaleTimeString()}: ${s.alarm.text}` : "");
    banner("fault-banner", running && s.fault ? "FAULT, torque off: " + s.fault_text : "");
    endedBanner(s);
    $("guide").hidden = running;
    enableButtons(fresh ? s : null);
    const live = running && fresh;
    if (!live && S.drawn) { clearLive(); S.drawn = false; }
    if (live && $("page-live").classList.contains("shown")) {
      S.drawn = true;
      $("t-session").textContent = s.t.toFixed(1) + " s";
      $("t-remaining").textContent = s.duration_s ? clock(Math.max(0, s.duration_s - s.t)) + " (of " + clock(s.duration_s) + ")" : "-";
      $("steps").textContent = s.steps;
      $("support").textContent = s.support === null ? "-" : (100 * s.support).toFixed(0) + " %";
      $("fault-live").textContent = s.fault ? s.fault_text : "";
      drawLeg(s); drawAngles(); drawTorques(s); drawFsr(s);
      $("phase").textContent = VOC().text.Phase[s.phase] || s.phase;
      const load = footLoad(s);
      $("foot-load").textContent = load === null ? "-" : load.toFixed(0) + " % body weight";
      $("gait-source").textContent = VOC().text.Source[s.gait_source] || s.gait_source;
      const bits = VOC().text.Limited.filter(([b]) => s.safety_status & b).map(([, n]) => n);
      $("safety").textContent = bits.length ? bits.join("; ") : "nominal";
      $("windings").textContent = s.winding_temp.map((v, i) => `${JOINTS[i]} ${v.toFixed(0)} °C`).join(", ");
      $("support-level").textContent = s.support_level.map((v, i) => `${JOINTS[i]} ${v === null ? "-" : v.toFixed(2)}`).join(", ");
      $("interaction").textContent = !drawCuffs(s) ? "not measured by this device"
        : s.interaction.map((v, i) => `${JOINTS[i]} ${v === null ? "-" : v.toFixed(1)} N m`).join(", ");
      $("events").innerHTML = S.events.map((e) => `<li>${esc(e)}</li>`).join("");
      $("t").textContent = s.t.toFixed(2) + " s";
      $("late").textContent = s.late_us.toFixed(1) + " us";
      $("late-max").textContent = s.late_max_us.toFixed(1) + " us";
      $("missed").textContent = s.missed;
    }
  }
}

// ---------------------------------------------------------------- control
async function refreshOperator() {
  const sent = S.operator;  // an answer to a request sent before control was taken says nothing of it
  const r = await call("GET", "/api/operator");
  if (!r.ok || sent !== S.operator) return;
  const h = r.data.holder;
  if (!r.data.you && S.operator && h) { S.operator = ""; sessionStorage.removeItem("exoleg-operator"); }
  $("hdr-operator").textContent = r.data.you ? `you (${h.name}) hold control` : (h ? `view only: ${h.name} holds control` : "view only");
  $("holder").textContent = h ? `Control is held by ${h.name} (${h.source}).` : "Nobody holds control.";
}

async function refreshInfo() {
  const r = await call("GET", "/api/info");
  if (!r.ok) return;
  S.info = r.data;
  const st = S.state || {};
  const d = r.data;
  $("session-line").textContent = (d.fixed ? "This interface serves the session run by `exoleg run`. " : "") +
    (d.session ? `Last session: ${d.session}. ` : "") + ` Backend: ${d.backend}.`;
  $("runs-on").textContent = d.records ? d.runs_on : "(enter the token to see the child's records)";
  for (const id of ["arm-start-line", "arm-start-note"]) $(id).style.display = d.simulated ? "" : "none";
  const kids = d.children || [];
  $("children").innerHTML = d.records ? (kids.map((c, i) => `<li><a href="#child" data-i="${i}">${esc(c.name)} (${esc(c.id)})` +
    (c.child.age ? `: ${c.child.age} y, ${(c.child.height * 100).toFixed(1)} cm, ${c.child.mass} kg` : "") +
    `, ${c.fits} fit(s), ${c.sessions} session(s)</a></li>`).join("") || "<li class='muted'>none yet</li>") :
    "<li class='muted'>The children's records need the token (Control page: Token).</li>";
  for (const a of $("children").querySelectorAll("a")) a.onclick = () => pickChild(kids[+a.dataset.i]);
  $("damaged-records").innerHTML = (d.damaged || []).map((x) => `<li>damaged, not listed: ${esc(x)}</li>`).join("");
  if (d.child && !$("fit-result").dataset.shown) showFit(d.child);
}

// the child's sessions over time, from the records (the figures kept when each ended),
// what their next session starts with, and the button that keeps their last fit
// The last child's history leaves the page the moment another child is picked (its
// "Keep ..." button must never be pressed for the wrong child), and an answer for a
// child picked before the current one is dropped.
async function showHistory(id, name) {
  S.historyOf = id;
  $("child-history").innerHTML = `<p class="muted">${esc(name)}'s sessions: reading the records...</p>`;
  const r = await call("GET", "/api/children/" + encodeURIComponent(id) + "/history");
  if (S.historyOf !== id) return;
  if (!r.ok) { $("child-history").innerHTML = ""; return; }
  const h = r.data, n = (x, d, u) => x === null || x === undefined ? "-" : x.toFixed(d) + (u || "");
  const helped = (a) => a ? JOINTS.map((j) => a[j] === null ? "-" : Math.round(100 * a[j])).join(" / ") + " %" : "-";
  $("child-history").innerHTML = `<h3>${esc(h.name)}'s sessions (${esc(h.child_id)})</h3>` +
    `<p><button id="keep-child" type="button">Keep ${esc(h.name)}'s last fit for the next session (no re-fit)</button></p>` +
    `<p id="history-settings">Their next session starts with ${esc(h.settings_text)}.</p>` +
    (h.sessions.length ? `<table id="history-table"><tr><th>date</th><th>walking</th><th>steps</th><th>cadence</th><th>GPS</th><th>support at the end</th><th>assistance ${JOINTS.join(" / ")}</th><th>operator</th><th>note</th></tr>` +
      h.sessions.map((s) => `<tr><td>${new Date(s.started * 1000).toLocaleString()}</td><td>${n(s.walk_time_s && s.walk_time_s / 60, 1, " min")}</td>` +
        `<td>${s.steps === null ? "-" : s.steps}</td><td>${n(s.cadence_steps_per_min, 0, " /min")}</td><td>${n(s.gps_deg, 1, " deg")}</td>` +
        `<td>${s.settings ? esc(s.settings.support_mode) : "-"}</td><td>${helped(s.assistance)}</td>` +
        `<td>${esc(s.operator || "-")}</td><td>${esc(s.note || "")}</td></tr>`).join("") + "</table>" : "<p class='muted'>No session yet.</p>") +
    (h.gps_change_deg === null ? "" : `<p id="history-trend">Gait Profile Score ${h.gps_change_deg >= 0 ? "+" : ""}${h.gps_change_deg.toFixed(1)} deg since the first session: ` +
      `${h.beyond_mcid ? "<b>beyond</b>" : "within"} the 1.6 deg that matters clinically.</p>`);
  $("keep-child").onclick = async () => {
    const k = await act("POST", "/api/children/" + encodeURIComponent(id) + "/keep", {}, `${h.name}'s last fit kept for the next session`);
    if (k.ok) { $("fit-result").dataset.shown = ""; refreshInfo(); }
  };
}

function pickChild(rec) {
  showHistory(rec.id, rec.name);
  const f = $("child-form"), c = rec.child;
  f.elements.child_id.value = rec.id;
  $("child-record").textContent = `${rec.name} (${rec.id}): a new fit of this child's record.`;
  f.elements.name.value = rec.name;
  if (!c.age) return;
  for (const k of ["age", "sex", "mass"]) f.elements[k].value = c[k];
  f.elements.height.value = (c.height * 100).toFixed(1);
  f.elements.gmfcs.value = c.gmfcs || 0;
  f.elements.side.value = c.affected_side;
  for (const k of ["thigh", "shank", "leg_length", "foot_length", "ankle_height"]) f.elements[k].value = c[k] ? (c[k] * 100).toFixed(1) : "";
  const a = rec.actor || {};
  for (const k of ["spasticity", "crouch", "contracture", "contracture_level", "strength"]) if (a[k] !== undefined) f.elements[k].value = a[k];
}

function showFit(f) {
  const cls = f.verdict === "FITS" ? "fits" : (f.fits ? "short" : "nofit");
  const margin = (x) => x === null ? "-" : x.toFixed(2);
  const rows = f.demand.map((r) => `<tr><td>${esc(r.source)}</td><td>${esc(r.quantity)}</td>` +
    JOINTS.map((j) => `<td class="${r[j + "_margin"] !== null && r[j + "_margin"] < 1 ? "over" : ""}">${margin(r[j + "_margin"])}</td>`).join("") + "</tr>").join("");
  $("fit-result").innerHTML = `<h3>${esc(f.child.name)} <span class="muted">(${esc(f.child_id || "")})</span></h3><p id="verdict" class="verdict ${cls}">${f.verdict}</p>
    ${f.actor_text ? `<p id="actor">On the simulated device, as an actor: ${esc(f.actor_text)}.</p>` : ""}
    <p>Telescopes: upper (hip-knee) <b>${(f.settings_m.upper * 100).toFixed(1)} cm</b> (27-40),
    lower (knee-sole) <b>${(f.settings_m.lower * 100).toFixed(1)} cm</b> (33-46); footplate 23.5 cm.</p>
    ${f.notes.length ? "<ul>" + f.notes.map((n) => `<li class="over">${esc(n)}</li>`).join("") + "</ul>" : ""}
    ${f.warnings.length ? "<ul>" + f.warnings.map((n) => `<li>${esc(n)}</li>`).join("") + "</ul>" : ""}
    <h3>Actuator margins (the actuators' limit from their datasheets / demand; below 1 is over the limit)</h3>
    <table><tr><th>source</th><th>quantity</th><th>hip</th><th>knee</th><th>ankle</th></tr>${rows}</table>
    <p class="muted">Kept for the next session started from the Control page.</p>`;
  $("fit-result").dataset.shown = "1";
}

$("child-form").addEventListener("submit", async (e) => {
  e.preventDefault();
  const body = Object.fromEntries(new FormData($("child-form")).entries());
  say("fitting...", true);
  const r = await act("POST", "/api/fit", body, "fitted and kept for the next session");
  if (r.ok) {
    showFit(r.data); refreshInfo();
    $("child-form").elements.child_id.value = r.data.child_id;
    $("child-record").textContent = `${r.data.child.name} (${r.data.child_id}): a new fit of this child's record.`;
  }
});
$("new-child").onclick = () => {
  $("child-form").elements.child_id.value = "";
  $("child-record").textContent = "A new child (or choose one fitted here, below).";
};

$("take").onclick = async () => {
  S.token = $("token").value.trim() || S.token;
  sessionStorage.setItem("exoleg-token", S.token);
  const r = await act("POST", "/api/operator", {name: $("op-name").value}, "you hold control");
  if (r.ok) { S.operator = r.data.operator; sessionStorage.setItem("exoleg-operator", S.operator); }
  refreshOperator();
};
$("release").onclick = async () => {
  await act("DELETE", "/api/operator", undefined, "control given up");
  S.operator = ""; sessionStorage.removeItem("exoleg-operator"); refreshOperator();
};
const freshLive = () => { S.hist = []; S.events = []; S.lastMode = null; S.lastEvent = -1; S.eventCount = 0; refreshInfo(); };
// each start its own id: a start the browser sends again (its reused connection dropped
// before the answer) is answered again by the server, not refused as another's session
const startId = () => Date.now().toString(36) + "-" + Math.random().toString(36).slice(2, 10);
// one start at a time: the buttons are off from the tap until the answer (a double tap
// on a phone would otherwise send a second start, refused as the first one's session)
async function startOnce(url, body, done) {
  if (S.startPending) return null;
  S.startPending = true;
  $("start").disabled = $("identify").disabled = true;
  try {
    return await act("POST", url, {...body, arm: $("arm-start").checked, request: startId()}, done);
  } finally {
    S.startPending = false;  // the buttons follow the next update (50 per second)
  }
}
$("start").onclick = async () => {
  const r = await startOnce("/api/session/start", {duration: $("duration").value}, "session started");
  if (r && r.ok) { say(`session ${r.data.session} started for ${r.data.text}`, true); freshLive(); }
};
$("identify").onclick = async () => {
  const r = await startOnce("/api/identify/start", {plan: $("plan").value}, "identification started");
  if (r && r.ok) { say(`identification ${r.data.session} started for ${r.data.text}: Arm, then Walk starts the plan`, true); freshLive(); }
};
const ARMED = () => VOC().armed || [];  // the modes in which the drives are enabled
$("end").onclick = async () => {
  const s = S.state || {};
  if (s.running === "running" && ARMED().includes(MODE(s.mode)) && !await confirmFirst(
    `End the session while ${MODE(s.mode)}? ` + (MODE(s.mode) === "STANDING" ? "The torque goes off: the device no longer holds the child's leg." :
      "The child is brought to a stand first (a controlled stop), then the torque goes off."))) { say("not ended", true); return; }
  act("POST", "/api/session/end", {}, "session ending: torque off once standing");
};
$("save-note").onclick = async () => {
  const r = await act("POST", "/api/session/note", {note: $("note").value}, "note kept");
  if (r.ok) $("note-line").textContent = `Kept with session ${r.data.session} (and in its control log).`;
};
for (const b of document.querySelectorAll("[data-command]"))
  b.onclick = async () => {
    const s = S.state || {};
    if (b.dataset.command === "disarm" && ARMED().includes(MODE(s.mode)) && !await confirmFirst(
      "Disarm? The torque goes off and the device no longer holds the child's leg.")) { say("not disarmed", true); return; }
    act("POST", "/api/command", {command: b.dataset.command}, b.dataset.command + " applied");
  };

// what each tunable is, in the operator's words and units
function gainWords(k) {
  if (k.startsWith("kp")) return "N m/rad";
  if (k.startsWith("kd")) return "N m s/rad";
  if (k === "inertia_share") return "0-1, the device's inertia the transparent law takes";
  if (k === "accel_filter_hz") return "Hz, the transparent law's acceleration estimate";
  return "0-1, assist as needed";
}

async function loadGains() {
  const r = await call("GET", "/api/gains");
  const t = $("gains");
  if (!r.ok || !r.data.gains || !r.data.gains.support) { t.innerHTML = "<tr><td class='muted'>no session running</td></tr>"; return; }
  const {gains, bounds} = r.data;
  t.innerHTML = "<tr><th></th>" + JOINTS.map((j) => `<th>${j}</th>`).join("") + "</tr>" +
    GAINS().map((k) => `<tr><td>${k} (${gainWords(k)})</td>` + gains[k].map((v, i) =>
      `<td><input id="g-${k}-${i}" inputmode="decimal" value="${+v.toFixed(3)}"><div class="bounds">${bounds[k][i][0]}-${+bounds[k][i][1].toFixed(3)}</div></td>`).join("") + "</tr>").join("") +
    `<tr><td>support (assistance)</td><td colspan="3"><input id="g-support-0" inputmode="decimal" value="${gains.support[0]}"><span class="bounds"> 0-1</span></td></tr>`;
}

$("apply-gains").onclick = async () => {
  const body = {};
  // as typed: the server reads decimal commas and refuses empty fields, in these words
  for (const k of GAINS()) body[k] = [0, 1, 2].map((i) => $(`g-${k}-${i}`).value);
  body.support = [$("g-support-0").value];
  const r = await act("POST", "/api/gains", body, "gains changed");
  if (r.ok) setTimeout(loadGains, 300);
};

// ---------------------------------------------------------------- sessions
async function loadSessions() {
  const r = await call("GET", "/api/sessions");
  $("sessions-note").textContent = r.ok ? (r.data.length ? "" : "No session recorded yet.") : (r.data.error || "the server does not answer");
  if (!r.ok) return;
  $("sessions").tBodies[0].innerHTML = r.data.map((s) => `<tr data-name="${esc(s.name)}"><td>${esc(s.name)}</td><td>${esc(s.child)}${s.child_id ? " (" + esc(s.child_id) + ")" : ""}</td>
    <td>${new Date(s.started * 1000).toLocaleString()}</td><td>${s.duration_s === null ? "-" : s.duration_s.toFixed(1) + " s"}</td>
    <td title="${esc(s.stopped_by)}">${esc(s.stopped_in_words || s.stopped_by)}</td><td>${esc(s.operator || "-")}</td><td>${esc(s.note || "")}</td><td class="${s.damaged.length ? "over" : ""}">${s.damaged.length ? "damaged: " + esc(s.damaged.join("; ")) : "whole"}</td></tr>`).join("");
  for (const tr of $("sessions").tBodies[0].rows) tr.onclick = () => openSession(tr.dataset.name);
}

// a session's figures in a clinician's words and units (exoleg.runtime.figures)
function clinical(f) {
  if (!f) return "<p class='muted'>No figures: the session is running, or its log holds nothing to read.</p>";
  const n = (x, d, u) => x === null || x === undefined ? "-" : x.toFixed(d) + (u || "");
  const per = (o, fmt) => o ? JOINTS.map((j) => fmt(o[j], j)).join(" / ") : "-";
  const helped = f.assistance ? per(f.assistance, (p) => {
    const v = Object.values(p).filter((x) => x !== null);
    return v.length ? Math.round(100 * v.reduce((a, b) => a + b, 0) / v.length) + " %" : "-";
  }) : "-";
  const cuffs = f.cuffs ? per(f.cuffs, (c) => `<span class="${c.limit_Nm_per_kg !== null && c.peak_Nm_per_kg > c.limit_Nm_per_kg ? "over" : ""}">${n(c.peak_Nm_per_kg, 2)}${c.limit_Nm_per_kg === null ? "" : " of " + c.limit_Nm_per_kg}</span>`) : "not measured";
  return `<h3>The session</h3><table id="session-clinical">
    <tr><td>how it ended</td><td>${esc(f.stopped_in_words)}</td></tr>
    <tr><td>time in the device, armed / walking</td><td>${n(f.up_time_s / 60, 1, " min")} / ${n(f.walk_time_s / 60, 1, " min")}</td></tr>
    <tr><td>steps, cadence</td><td>${f.steps} steps, ${n(f.cadence_steps_per_min, 0, " steps/min")}</td></tr>
    <tr><td>stride time, stance</td><td>${f.stride_time_s ? f.stride_time_s[0].toFixed(2) + " ± " + f.stride_time_s[1].toFixed(2) + " s" : "-"}, ${n(f.stance_percent, 0, " % of the stride")}</td></tr>
    <tr><td>Gait Profile Score</td><td>${n(f.gps_deg, 1, " deg")}</td></tr>
    <tr><td>range of motion ${JOINTS.join(" / ")} (typical)</td><td>${per(f.rom_deg, (x, j) => n(x, 0) + " (" + n(f.normative_rom_deg[j], 0) + ")")} deg</td></tr>
    <tr><td>assistance ${JOINTS.join(" / ")} (walking)</td><td>${helped}</td></tr>
    <tr><td>cuffs' peak torque ${JOINTS.join(" / ")} (of the limit)</td><td>${cuffs}${f.cuffs ? " N m/kg" : ""}</td></tr>
    <tr><td>safety events</td><td>${f.safety_events && f.safety_events.length ? f.safety_events.map((e) => `${esc(e.text)} (first at ${e.first_s.toFixed(1)} s, ${e.ticks} ticks)`).join("; ") : "none"}</td></tr></table>`;
}

async function openSession(name) {
  const r = await call("GET", "/api/sessions/" + encodeURIComponent(name));
  if (!r.ok) { say("refused: " + r.data.error, false); return; }
  const d = r.data, L = d.log, base = "/api/sessions/" + encodeURIComponent(name);
  const damaged = d.damaged.length ? `<ul class="over">${d.damaged.map((x) => `<li>damaged: ${esc(x)}</li>`).join("")}</ul>` : "";
  if (L.error) { $("session-detail").innerHTML = `<h3>${esc(name)}</h3><p class="over">${esc(d.stopped_by)}</p>${damaged}<p>${esc(L.error)}</p>`; return; }
  $("session-detail").innerHTML = `<h3>${esc(name)}</h3>${damaged}
    <p><a id="session-report" href="#sessions" data-file="${base}/report.pdf" data-name="${esc(name)}-report.pdf"><b>Report (PDF)</b></a> · <a id="export-c3d" href="#sessions" data-file="${base}/session.c3d" data-name="${esc(name)}.c3d">Export C3D</a> · <a id="export-csv" href="#sessions" data-file="${base}/session.csv" data-name="${esc(name)}.csv">Export CSV</a> · <a id="export-parquet" href="#sessions" data-file="${base}/session.parquet" data-name="${esc(name)}.parquet">Export Parquet</a></p>
    ${clinical(d.figures)}
    <h3>For the engineer</h3>
    <table><tr><td>child</td><td>${esc(d.child)}</td></tr><tr><td>backend</td><td>${L.backend}</td></tr>
    <tr><td>duration</td><td>${L.duration_s.toFixed(2)} s (${L.ticks} ticks)</td></tr>
    <tr><td>ended by</td><td>${esc(d.stopped_by)}</td></tr>
    <tr><td>first fault</td><td>${L.first_fault_s === null ? "none" : L.first_fault_s.toFixed(3) + " s"}</td></tr>
    <tr><td>initial contacts</td><td>${L.initial_contacts}</td></tr>
    <tr><td>lateness p50 / p99 / max</td><td>${L.late_p50_us.toFixed(1)} / ${L.late_p99_us.toFixed(1)} / ${L.late_max_us.toFixed(0)} us</td></tr>
    <tr><td>deadlines missed</td><td>${L.missed_deadlines}</td></tr></table>
    <p><img id="session-plot" alt="session plot"></p>
    <h3>Control actions</h3><table><tr><th>time</th><th>source</th><th>action</th><th>accepted</th><th>note</th></tr>
    ${d.control.map((a) => `<tr><td>${new Date(a.time * 1000).toLocaleTimeString()}</td><td>${esc(a.source)}</td><td>${esc(a.command)}</td>
      <td>${a.accepted ? "yes" : "no"}</td><td>${esc(a.why || (a.after_click_ms !== undefined ? a.after_click_ms + " ms after the click" : (a.after_request_ms !== undefined ? a.after_request_ms + " ms after the request" : "")))}</td></tr>`).join("")}</table>`;
  wireSessionFiles(base);
}

// the records need the token: files are fetched with it, never by an address that holds it
async function fetched(url) {
  const headers = S.token ? {"Authorization": "Bearer " + S.token} : {};
  const r = await fetch(url, {headers});
  if (!r.ok) throw new Error((await r.json().catch(() => ({}))).error || r.status);
  return URL.createObjectURL(await r.blob());
}

function wireSessionFiles(base) {
  fetched(base + "/plot.png").then((u) => { $("session-plot").src = u; }).catch((e) => say("plot: " + e.message, false));
  for (const a of document.querySelectorAll("[data-file]"))
    a.onclick = async (e) => {
      e.preventDefault();
      try {
        const link = document.createElement("a");
        link.href = await fetched(a.dataset.file); link.download = a.dataset.name; link.click();
      } catch (err) { say("export: " + err.message, false); }
    };
}

// ---------------------------------------------------------------- start
(function init() {
  const m = location.hash.match(/token=([^&]+)/);
  S.token = m ? decodeURIComponent(m[1]) : (sessionStorage.getItem("exoleg-token") || "");
  if (m) { sessionStorage.setItem("exoleg-token", S.token); history.replaceState(null, "", location.pathname + "#live"); }
  $("token").value = S.token;
  show(); connect(); refreshInfo(); refreshOperator();
  setInterval(() => {
    refreshOperator();
    if (S.state && S.state.running === "running" && !$("g-support-0")) loadGains();
  }, 1000);
  setInterval(refreshInfo, 3000);
  requestAnimationFrame(frame);
})();
