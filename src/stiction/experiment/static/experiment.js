// The participant's page: what the session shows (instructions, progress,
// the start dot, the pointer and string, the answer buttons) and nothing
// else. It never receives the stimulus's parameters, so it cannot show them.
// Drawing reuses the renderer's colours and string geometry (draw.js).

import { COLORS, POINTER_RADIUS, STRING_WIDTH, cssScale, stringEnd } from "/static/draw.js";

const canvas = document.getElementById("view");
const panel = document.getElementById("panel");
const textEl = document.getElementById("text");
const ratioEl = document.getElementById("ratio");
const buttonsEl = document.getElementById("buttons");
const progressEl = document.getElementById("progress");
const banner = document.getElementById("banner");

const LABELS = {
  start: "Start",
  first: "First surface",
  second: "Second surface",
  confirm: "Confirm",
  "-0.10": "decrease (-0.10)",
  "-0.05": "slight decrease (-0.05)",
  "-0.01": "slightest decrease (-0.01)",
  "+0.01": "slightest increase (+0.01)",
  "+0.05": "slight increase (+0.05)",
  "+0.10": "increase (+0.10)",
};
const DOT_RADIUS = 14;

const state = { view: null, frame: null, dirty: true, send: null };
window.experiment = { view: null, presses: 0, refused: null, drawn: 0 };

function label(id) { return LABELS[id] || id; }

function showView(v) {
  state.view = v;
  window.experiment.view = v;
  if (Array.isArray(v.display) && (canvas.width !== v.display[0] || canvas.height !== v.display[1])) {
    [canvas.width, canvas.height] = v.display;
  }
  progressEl.textContent = v.state === "instructions" || v.state === "done" ? ""
    : `Trial ${v.trial} of ${v.trials}` + (v.stimulus ? ` · surface ${v.stimulus} of 2` : "");
  const drawing = v.state === "stimulus";
  panel.hidden = drawing;
  textEl.textContent = v.text || v.question || "";
  ratioEl.hidden = v.ratio === undefined;
  if (v.ratio !== undefined) ratioEl.textContent = v.ratio.toFixed(2);
  buttonsEl.replaceChildren(...(v.buttons || []).map((id) => {
    const b = document.createElement("button");
    b.type = "button";
    b.dataset.press = id;
    b.textContent = label(id);
    if (id === "confirm" || id === "start") b.classList.add("confirm");
    b.addEventListener("click", () => press(id));
    return b;
  }));
  state.dirty = true;
}

function press(id) {
  if (!state.send) return;
  state.send(JSON.stringify({ press: id }));
  window.experiment.presses += 1;
}

function draw() {
  requestAnimationFrame(draw);
  if (!state.dirty) return;
  state.dirty = false;
  const ctx = canvas.getContext("2d");
  const k = cssScale(canvas);
  ctx.fillStyle = COLORS.background;
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const v = state.view;
  if (!v || v.state !== "stimulus") return;
  const f = state.frame;
  const touching = f && f.pointer && f.touching;
  if (!touching) { // where to put the pen down
    ctx.strokeStyle = COLORS.pointer;
    ctx.lineWidth = 2 * k;
    ctx.beginPath();
    ctx.arc(canvas.width / 2, canvas.height / 2, DOT_RADIUS * k, 0, 2 * Math.PI);
    ctx.stroke();
  }
  if (touching) {
    const [px, py] = f.pointer;
    const end = f.string ? stringEnd({ pointer_px: f.pointer, string: f.string }) : null;
    if (end && f.string.length_px > 0) {
      ctx.strokeStyle = COLORS.string;
      ctx.lineWidth = STRING_WIDTH * k;
      ctx.lineCap = "round";
      ctx.beginPath();
      ctx.moveTo(px, py);
      ctx.lineTo(end[0], end[1]);
      ctx.stroke();
    }
    ctx.fillStyle = COLORS.pointer;
    ctx.beginPath();
    ctx.arc(px, py, POINTER_RADIUS * k, 0, 2 * Math.PI);
    ctx.fill();
  }
  window.experiment.drawn += 1;
}

// The page's one WebSocket: views and frames in, presses out; reconnects
// with backoff, and the session sends its current view on every connect, so
// a reloaded or reconnected page loses nothing.
const proto = location.protocol === "https:" ? "wss:" : "ws:";
let delay = 250;
function open() {
  const ws = new WebSocket(`${proto}//${location.host}/ws`);
  ws.onopen = () => { delay = 250; banner.hidden = true; state.send = (t) => ws.send(t); };
  ws.onmessage = (ev) => {
    let msg;
    try { msg = JSON.parse(ev.data); } catch (err) { return; }
    if (msg.type === "view") showView(msg);
    else if (msg.type === "frame") { state.frame = msg; state.dirty = true; }
    else if (msg.type === "refused") window.experiment.refused = msg.error;
  };
  ws.onclose = () => {
    state.send = null;
    banner.hidden = false;
    banner.textContent = "Lost the connection to the experiment; reconnecting…";
    setTimeout(open, delay);
    delay = Math.min(delay * 2, 4000);
  };
}
open();
requestAnimationFrame(draw);
