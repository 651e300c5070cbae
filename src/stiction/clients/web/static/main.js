// The renderer: keeps the latest scene and the latest frame of each device,
// and draws on requestAnimationFrame only when something changed. Messages
// that arrive between two animation frames overwrite each other, so the
// screen always shows the newest state and nothing stale is ever queued.

import { connect } from "./link.js";
import { drawAll } from "./draw.js";
import { RateMeter, daemonRate, statusText } from "./status.js";

const canvas = document.getElementById("view");
const banner = document.getElementById("banner");
const statusEl = document.getElementById("status");

const state = {
  scene: null,
  frames: new Map(),       // device -> latest frame
  prevFrame: new Map(),    // device -> an earlier frame, for the daemon's rate
  link: { state: "connecting", message: "connecting to the bridge…" },
  latencyMs: null,
  receivedAt: null,
  screenMs: null,
  tickRate: null,
  dirty: true,
};
const receiveMeter = new RateMeter();
const drawMeter = new RateMeter();

// What tests (and curious users, from the console) can read.
window.stiction = { received: 0, drawn: 0, drawnTick: null, status: "connecting", scene: null };

function sizeCanvas() {
  let w, h;
  if (state.scene && Array.isArray(state.scene.display)) {
    [w, h] = state.scene.display;
  } else { // no scene yet: the display's own pixel size
    w = Math.round(screen.width * devicePixelRatio);
    h = Math.round(screen.height * devicePixelRatio);
  }
  if (canvas.width !== w || canvas.height !== h) {
    canvas.width = w;
    canvas.height = h;
    if (document.fullscreenElement) fitExactly();
  }
}

function showBanner(text) {
  banner.hidden = !text;
  banner.textContent = text || "";
}

function onMessage(msg, now) {
  switch (msg.type) {
    case "frame": {
      const f = msg.frame;
      const prev = state.prevFrame.get(f.device);
      if (!prev || f.t - prev.t >= 0.5 || f.tick < prev.tick) {
        const r = daemonRate(prev, f);
        if (r !== null) state.tickRate = r;
        state.prevFrame.set(f.device, f);
      }
      state.frames.set(f.device, f);
      state.latencyMs = msg.latency_ms;
      state.receivedAt = now;
      receiveMeter.tick(now);
      window.stiction.received += 1;
      break;
    }
    case "scene":
      state.scene = msg.scene;
      window.stiction.scene = msg.scene;
      sizeCanvas();
      break;
    case "status":
      state.link = { state: msg.state, message: msg.message, reason: msg.reason || null };
      window.stiction.status = msg.state;
      window.stiction.reason = msg.reason || null;
      // "no-device": the daemon answers but has nothing to read yet; say so as loudly as an outage.
      const loud = msg.state === "gone" || msg.state === "error" || msg.reason === "no-device";
      showBanner(loud ? msg.message : "");
      break;
    default:
      break;
  }
  state.dirty = true;
}

function render(now) {
  requestAnimationFrame(render);
  const frames = [...state.frames.values()];
  if (state.dirty) {
    state.dirty = false;
    drawAll(canvas, state.scene, frames);
    drawMeter.tick(now);
    if (frames.length && state.receivedAt !== null) {
      state.screenMs = Math.max(0, now - state.receivedAt); // rAF's clock starts the frame
      window.stiction.drawnTick = Math.max(...frames.map((f) => f.tick));
    }
    window.stiction.drawn += 1;
  }
  const s = statusText({
    link: state.link,
    frames,
    drawRate: drawMeter.rate(now),
    receiveRate: receiveMeter.rate(now),
    tickRate: state.tickRate,
    latencyMs: state.latencyMs,
    screenMs: state.screenMs,
    now,
    receivedAt: state.receivedAt,
  });
  window.stiction.statusState = s.state;
  const line = `● ${s.state.padEnd(10)} ${s.text.replace("\n", "\n             ")}`;
  if (statusEl.textContent !== line) {
    statusEl.textContent = line;
    statusEl.className = "";
    statusEl.classList.add(s.state);
  }
}

// "f": full screen with one canvas pixel per device pixel, as an experiment
// display needs (the scene's display size should then equal the screen's).
function fitExactly() {
  const exact = document.fullscreenElement !== null;
  document.body.classList.toggle("exact", exact);
  canvas.style.width = exact ? `${canvas.width / devicePixelRatio}px` : "";
  canvas.style.height = exact ? `${canvas.height / devicePixelRatio}px` : "";
}
document.addEventListener("keydown", (ev) => {
  if (ev.key !== "f" || ev.repeat) return;
  if (document.fullscreenElement) document.exitFullscreen();
  else document.documentElement.requestFullscreen().catch((err) => console.warn(err));
});
document.addEventListener("fullscreenchange", fitExactly);

sizeCanvas();
const proto = location.protocol === "https:" ? "wss:" : "ws:";
// The access token of a non-loopback `stiction web` comes in the page's URL.
const token = new URLSearchParams(location.search).get("token");
const wsUrl = `${proto}//${location.host}/ws` + (token ? `?token=${encodeURIComponent(token)}` : "");
connect(wsUrl, {
  onMessage,
  onOpen: () => { state.link = { state: "connected", message: "" }; showBanner(""); state.dirty = true; },
  onClose: (delay) => {
    state.link = { state: "gone", message: "" };
    window.stiction.status = "bridge-lost";
    showBanner(`Lost the connection to the bridge (stiction web); retrying in ${(delay / 1000).toFixed(1)} s…`);
    state.dirty = true;
  },
});
requestAnimationFrame(render);
