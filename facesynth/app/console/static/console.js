// facesynth rig console: talks to `facesynth console` (facesynth/app/console/protocol.py).
// It reconnects by itself and always says what state it is in: never a silent dead page.
"use strict";

const state = {
  status: "connecting", // "open" | "closed" | "connecting"
  connects: 0,
  trusted: false,
  heldBy: null, // null | "you" | "other"
  control: null,
  servos: [],
  positions: [],
  measured: [],
  faults: [],
  targets: [],
  errors: [],
  saved: null,
  calibration: null,
  framesDrawn: 0,
  points: null,
};
window.facesynth = state;

const $ = (id) => document.getElementById(id);
const token = new URLSearchParams(location.hash.slice(1)).get("token") || "";
const onFrame = frameView(state);
let rows = [];

function send(message) {
  if (link.open()) {
    link.send(message);
    return true;
  }
  showError("not connected: the console is not reachable (is `facesynth console` running?)");
  return false;
}
window.consoleSend = send;

function setStatus(status) {
  state.status = status;
  const el = $("status");
  el.className = "pill " + status;
  el.textContent = { open: "connected", closed: "disconnected", connecting: "connecting…" }[status];
  const banner = $("banner");
  banner.hidden = status === "open";
  banner.textContent = status === "closed"
    ? "Disconnected from the console: retrying… (servos return to neutral when no page holds them)"
    : "Connecting to the console…";
}

function showError(text) {
  state.errors.push(text);
  $("error-text").textContent = text;
  $("error").hidden = false;
}
$("error-close").onclick = () => { $("error").hidden = true; };

function onText(m) {
  switch (m.type) {
    case "hello": return onHello(m);
    case "welcome": return onWelcome(m);
    case "state": return onState(m);
    case "stats": return onStats(m.services);
    case "points": state.points = m; return;
    case "control": return onControl(m.state);
    case "calibration": return onCalibration(m);
    case "saved": state.saved = m;
      $("save-info").textContent = `saved ${m.path}` + (m.backup ? ` (previous: ${m.backup})` : "");
      return;
    case "released": return;
    case "error": return showError(m.message);
    case "pong": $("rtt").textContent = `page round trip ${(performance.now() - m.t).toFixed(1)} ms`;
      return;
  }
}

function onWelcome(m) {
  state.trusted = m.trusted;
  const el = $("trust");
  el.className = "pill" + (m.trusted ? " trusted" : "");
  el.textContent = m.trusted ? "token ok" : "watching (no token)";
  if (!m.trusted) showError("This page has no token: it can watch but not move servos. Open the address the console printed (…/#token=…).");
}

function onControl(value) {
  state.control = value;
  const el = $("control");
  el.className = "pill " + value.split(":")[0];
  el.textContent = `C: ${value}`;
}

function cell(row, html) {
  const td = document.createElement("td");
  if (html !== undefined) td.innerHTML = html;
  row.appendChild(td);
  return td;
}

function onHello(m) {
  $("profile").textContent = `profile ${m.profile} → ${m.save_to}`;
  onControl(m.control);
  $("calibrate").disabled = !m.calibration;
  if (!m.calibration) $("calib-result").textContent = "start the console with --camera N or --video FILE to calibrate";
  if (m.face_page) { $("face-panel").hidden = false; if ($("face-page").src !== m.face_page) $("face-page").src = m.face_page; }
  if (m.robot_camera) { $("camera-panel").hidden = false; if ($("robot-camera").src !== m.robot_camera) $("robot-camera").src = m.robot_camera; }
  state.servos = m.servos;
  const body = document.querySelector("#servos tbody");
  body.replaceChildren();
  const bars = $("bars");
  bars.replaceChildren();
  rows = m.servos.map((s) => {
    const row = document.createElement("tr");
    row.dataset.servo = s.index;
    cell(row, String(s.index));
    cell(row, String(s.channel));
    const name = cell(row, '<input class="servo-name">').firstChild;
    name.value = s.name;
    name.onchange = () => send({ type: "rename", servo: s.index, name: name.value });
    name.parentNode.className = "name";
    const jog = cell(row, '<input type="range" class="jog" step="1">').firstChild;
    jog.parentNode.className = "jog";
    jog.min = s.low; jog.max = s.high; jog.value = s.neutral;
    let pending = null;
    jog.oninput = () => {
      if (pending === null) setTimeout(() => { send({ type: "jog", servo: s.index, us: pending }); pending = null; }, 30);
      pending = Number(jog.value);
    };
    const target = cell(row, "–");
    const at = cell(row, "–");
    const measured = cell(row, "–");
    measured.className = "measured";
    const limits = {};
    for (const which of ["min", "neutral", "max"]) {
      const input = cell(row, '<input type="number" step="1">').firstChild;
      input.parentNode.className = "limit";
      input.value = s[which];
      input.className = `limit-${which}`;
      input.onchange = () => send({ type: "limit", servo: s.index, which, us: Number(input.value) });
      limits[which] = input;
    }
    const here = cell(row);
    for (const which of ["min", "neutral", "max"]) {
      const b = document.createElement("button");
      b.textContent = which;
      b.className = `here-${which}`;
      b.title = `set ${which} to where the servo stands`;
      b.onclick = () => send({ type: "limit", servo: s.index, which });
      here.appendChild(b);
    }
    const rev = cell(row, '<input type="checkbox" class="reversed">').firstChild;
    rev.checked = s.reversed;
    rev.onchange = () => send({ type: "reverse", servo: s.index, reversed: rev.checked });
    body.appendChild(row);
    const bar = servoBar(s.name, s.min, s.neutral, s.max);
    bars.appendChild(bar.element);
    return { s, jog, target, at, measured, limits, bar };
  });
}

function onState(m) {
  state.positions = m.positions;
  state.measured = m.measured || [];
  state.faults = m.faults || [];
  state.targets = m.targets;
  state.heldBy = m.held_by;
  state.holding = m.holding;
  state.dirty = m.dirty;
  const held = $("held");
  held.className = "pill " + (m.held_by || "");
  held.textContent = m.held_by === "you" ? "you hold the servos"
    : m.held_by === "other" ? "another page holds the servos"
    : m.holding ? "servos stopped (let go to free them)" : "servos free";
  $("save").textContent = m.dirty ? "save profile *" : "save profile";
  rows.forEach((r, i) => {
    const p = m.positions[i];
    const t = m.targets[i];
    r.target.textContent = m.holding ? t.toFixed(0) : "–";
    r.at.textContent = p.toFixed(0);
    const measured = state.measured[i];
    const fault = state.faults[i] || "";
    r.measured.textContent = (measured === null || measured === undefined ? "–" : measured.toFixed(0))
      + (fault ? ` ⚠ ${fault}` : "");
    r.measured.classList.toggle("fault", fault !== "");
    r.measured.title = fault ? `the servo reports: ${fault}` : "";
    if (document.activeElement !== r.jog && m.holding) r.jog.value = t;
    r.bar.show(p, measured);
  });
}

function onCalibration(m) {
  state.calibration = m;
  if (m.state === "running" || m.state === "starting") {
    $("calib-step").textContent = m.step ? m.step.replace(/_/g, " ").toUpperCase() : m.state;
    $("calib-prompt").textContent = m.prompt || "";
    $("calib-left").textContent = m.left_s === null || m.left_s === undefined ? "" : `${Math.ceil(m.left_s)}`;
    $("calib-result").textContent = "";
  } else if (m.state === "done") {
    $("calib-step").textContent = "done";
    $("calib-left").textContent = "";
    $("calib-prompt").textContent = "";
    $("calib-result").textContent = `calibration ${m.name} written to ${m.path}: use --calibration ${m.name}`;
  } else if (m.state === "failed") {
    $("calib-step").textContent = "failed";
    $("calib-left").textContent = "";
    showError(`calibration ${m.name}: ${m.error}`);
  }
}

function onStats(services) {
  const c = services.find((s) => s.service === "control");
  $("board").textContent = c ? `board: ${c.note || "–"}${c.status === "running" ? "" : ` (C ${c.status})`}` : "";
  showStages(services, true);
}

$("take").onclick = () => send({ type: "take" });
$("release").onclick = () => send({ type: "release" });
$("centre").onclick = () => send({ type: "centre" });
$("neutral").onclick = () => send({ type: "neutral" });
$("stop").onclick = () => send({ type: "stop" });
$("save").onclick = () => send({ type: "save" });
$("calibrate").onclick = () => send({ type: "calibrate", name: $("calib-name").value });

// A token pasted into the address bar (a new #fragment) does not reload a page: reload it.
window.addEventListener("hashchange", () => location.reload());

const link = pageLink(state, {
  status: setStatus,
  hello: () => ({ type: "hello", token }),
  text: onText,
  binary: onFrame,
  closed: () => {
    state.trusted = false;
    state.heldBy = null;
  },
});
