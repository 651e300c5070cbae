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

export function statusText({ link, frames, drawRate, receiveRate, tickRate, latencyMs, screenMs }) {
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
  const lat = latencyMs === null ? "tick→bridge n/a" : `tick→bridge ${fmt(latencyMs, 1)} ms`;
  parts.push(`latency ${lat} + bridge→screen ${fmt(screenMs, 1)} ms`);
  // Two lines: what the pen is doing, then how the pipeline is doing.
  return { state: link.state, text: `${parts[0]}\n${parts.slice(1).join("   ·   ")}` };
}
