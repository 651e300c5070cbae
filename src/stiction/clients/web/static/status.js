// The status line: what a person checks at a glance while drawing.

// Rates over a sliding one-second window of timestamps (ms).
export class RateMeter {
  constructor() { this.times = []; }
  tick(now) {
    this.times.push(now);
    while (this.times.length && now - this.times[0] > 1000) this.times.shift();
  }
  rate(now) {
    while (this.times.length && now - this.times[0] > 1000) this.times.shift();
    return this.times.length;
  }
}

// The daemon's own frame rate, from tick numbers and tick times (not arrival):
// 100/s while something happens, one keep-alive a second while it idles.
export function daemonRate(prev, frame) {
  if (!prev || frame.t <= prev.t || frame.tick <= prev.tick) return null;
  return (frame.tick - prev.tick) / (frame.t - prev.t);
}

const fmt = (x, digits) => (x === null || x === undefined || !Number.isFinite(x) ? "–" : x.toFixed(digits));

export const STALE_MS = 2500;
// Past this long without a frame the rates and latencies describe the past:
// the status says how long it has been instead of showing them.

export function statusText({
  link, frames, drawRate, receiveRate, tickRate, latencyMs, screenMs, now = 0, receivedAt = null,
}) {
  if (link.state === "connecting" || (link.state !== "gone" && receivedAt === null && !frames.length)) {
    const what = link.state === "connecting"
      ? "connecting to the bridge (stiction web)…"
      : link.reason === "no-device" ? link.message : "waiting for the first frame from stictiond…";
    return { state: link.state === "connecting" ? "connecting" : link.state, text: `${what}\n ` };
  }
  const silentMs = receivedAt === null ? null : now - receivedAt;
  if (link.state === "gone" || (silentMs !== null && silentMs > STALE_MS)) {
    const since = silentMs === null ? "" : ` for ${(silentMs / 1000).toFixed(0)} s`;
    const why = link.state === "gone" ? "no connection to the bridge" : "no frames from stictiond";
    return { state: link.state === "gone" ? "gone" : "stale", text: `${why}${since}: the picture shows the last state\n ` };
  }
  const parts = [];
  const contacts = [];
  for (const f of frames) {
    for (const c of f.contacts || []) {
      const s = c.string ? `  string ${fmt(c.string.length_px, 1)} px` : "";
      contacts.push(`${f.device} #${c.id} ${c.phase}  T ${c.tension.toExponential(2)} N${s}  ${c.material}`);
    }
  }
  parts.push(contacts.length ? contacts.join("  |  ") : frames.length ? `${frames.map((f) => f.device).join(", ")}: no contact` : "no device yet");
  parts.push(`daemon ${fmt(tickRate, 0)} frames/s, received ${receiveRate}/s, drawn ${drawRate}/s`);
  // A negative latency means the two clocks disagree (start-up, another
  // machine): not a figure worth showing.
  const lat = latencyMs === null || latencyMs < 0 ? "tick→bridge –" : `tick→bridge ${fmt(latencyMs, 1)} ms`;
  parts.push(`latency ${lat} + bridge→screen ${fmt(screenMs, 1)} ms`);
  // Two lines: what the pen is doing, then how the pipeline is doing.
  return { state: link.state, text: `${parts[0]}\n${parts.slice(1).join("   ·   ")}` };
}
