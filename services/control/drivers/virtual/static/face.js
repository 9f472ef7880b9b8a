// facesynth live face: draws what the server sends (see services/control/drivers/virtual/wire.py).
// The face's shapes are computed in Python; this page only draws them. It reconnects by itself.
"use strict";

const state = {
  status: "connecting", // "open" | "closed" | "connecting"
  connects: 0,
  profile: null,
  drawsFace: false,
  face: null, // the last face message
  drawn: 0, // face messages drawn
  framesDrawn: 0,
  points: null,
  rttMs: null,
};
window.facesynth = state;

const $ = (id) => document.getElementById(id);
const faceCanvas = $("face");
const faceCtx = faceCanvas.getContext("2d");
const onFrame = frameView(state);
const showFrames = $("show-frames");
let bars = new Map();

function setStatus(status) {
  state.status = status;
  const el = $("status");
  el.className = "pill " + status;
  el.textContent = { open: "live", closed: "reconnecting…", connecting: "connecting…" }[status];
}

function onText(message) {
  switch (message.type) {
    case "hello": return onHello(message);
    case "face": return onFace(message);
    case "points": state.points = message; return;
    case "stats": return showStages(message.services, false);
    case "pong": state.rttMs = performance.now() - message.t;
      $("rtt").textContent = `page round trip ${state.rttMs.toFixed(1)} ms`; return;
  }
}

function onHello(message) {
  state.profile = message.profile;
  state.drawsFace = message.face;
  $("profile").textContent = `profile ${message.profile}`;
  $("face-panel").hidden = !message.face;
  const box = $("bars");
  box.replaceChildren();
  bars = new Map();
  for (const c of message.controls) {
    const bar = servoBar(c.name, c.low, c.neutral, c.high);
    box.appendChild(bar.element);
    bars.set(c.name, bar);
  }
}

function onFace(message) {
  state.face = message;
  const tracking = $("tracking");
  tracking.textContent = message.seq === null ? "neutral" : message.face ? "tracking" : "no face";
  tracking.className = "pill" + (message.face ? " open" : " noface");
  $("face-info").textContent = message.seq === null ? "" : `frame ${message.seq}`;
  for (const [name, value] of Object.entries(message.controls)) {
    const bar = bars.get(name);
    if (bar) bar.show(value);
  }
  if (message.shapes) drawShapes(faceCtx, message.shapes);
  state.drawn += 1;
}

// Draws the shapes of geometry.py exactly as facesynth/app/render/draw.py does with OpenCV.
function drawShapes(ctx, shapes) {
  ctx.clearRect(0, 0, ctx.canvas.width, ctx.canvas.height);
  ctx.lineJoin = "round";
  ctx.lineCap = "round";
  for (const s of shapes) {
    ctx.beginPath();
    if (s.kind === "circle") {
      ctx.arc(s.points[0][0], s.points[0][1], s.radius, 0, 2 * Math.PI);
    } else {
      ctx.moveTo(s.points[0][0], s.points[0][1]);
      for (let i = 1; i < s.points.length; i++) ctx.lineTo(s.points[i][0], s.points[i][1]);
      if (s.kind === "polygon") ctx.closePath();
    }
    if (s.fill && s.kind !== "polyline") { ctx.fillStyle = s.fill; ctx.fill(); }
    if (s.stroke) { ctx.strokeStyle = s.stroke; ctx.lineWidth = s.width; ctx.stroke(); }
  }
}

showFrames.addEventListener("change", () => {
  $("performer-panel").classList.toggle("off", !showFrames.checked);
  if (link.open()) link.send({ type: "hello", frames: showFrames.checked });
});

const link = pageLink(state, {
  status: setStatus,
  hello: () => ({ type: "hello", frames: showFrames.checked }),
  text: onText,
  binary: onFrame,
});
