#!/usr/bin/env node
// A stiction client in Node.js, written from docs/protocol.md alone: it
// subscribes to a running stictiond and prints the frames it receives.
//
//   node subscribe.mjs [ENDPOINT] [--control ENDPOINT] [--count N] [--json] [--device NAME]
//
// With --control it follows the protocol's "clone" pattern: subscribe first,
// then ask for a snapshot, print the snapshot's frames and drop every streamed
// frame whose tick the snapshot already covered.

import { Subscriber, Request } from "zeromq";
import { decode, encode } from "@msgpack/msgpack";

const SCHEMA_VERSION = 1; // the version this client was written for

function usage(message) {
  if (message) console.error(`subscribe.mjs: ${message}`);
  console.error("usage: node subscribe.mjs [ENDPOINT] [--control ENDPOINT] [--count N] [--json] [--device NAME]");
  process.exit(2);
}

function parseArgs(argv) {
  const opts = { endpoint: "tcp://127.0.0.1:5556", control: null, count: Infinity, json: false, devices: [] };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    const value = () => (i + 1 < argv.length ? argv[++i] : usage(`${a} needs a value`));
    if (a === "--control") opts.control = value();
    else if (a === "--count") {
      opts.count = Number(value());
      if (!Number.isInteger(opts.count) || opts.count < 0) usage("--count must be a whole number");
    } else if (a === "--json") opts.json = true;
    else if (a === "--device") opts.devices.push(value());
    else if (a === "-h" || a === "--help") usage();
    else if (a.startsWith("--")) usage(`unknown option ${a}`);
    else opts.endpoint = a;
  }
  return opts;
}

// Refuse what could be misread; ignore keys we do not know (protocol.md, "Encoding").
class ProtocolError extends Error {}

function checkVersion(msg) {
  if (msg === null || typeof msg !== "object" || Array.isArray(msg)) throw new ProtocolError("message is not a map");
  if (!Number.isInteger(msg.v)) throw new ProtocolError("message has no integer schema version 'v'");
  if (msg.v > SCHEMA_VERSION) {
    const err = new ProtocolError(`message uses schema version ${msg.v}, newer than this client's ${SCHEMA_VERSION}`);
    err.fatal = true;
    throw err;
  }
}

const isNum = (x) => typeof x === "number" && Number.isFinite(x);
const isVec = (x) => Array.isArray(x) && x.length === 2 && isNum(x[0]) && isNum(x[1]);
const PHASES = new Set(["stick", "slip", "hover", "up"]);

function checkFrame(msg) {
  checkVersion(msg);
  if (msg.kind !== "frame") throw new ProtocolError(`expected kind "frame", got ${JSON.stringify(msg.kind)}`);
  if (!Number.isInteger(msg.tick) || !isNum(msg.t) || typeof msg.device !== "string") {
    throw new ProtocolError("frame needs integer tick, number t and string device");
  }
  if (!(msg.t_input === null || msg.t_input === undefined || isNum(msg.t_input))) throw new ProtocolError("bad t_input");
  if (!Array.isArray(msg.contacts)) throw new ProtocolError("frame contacts must be a list");
  for (const c of msg.contacts) {
    if (!Number.isInteger(c.id) || !PHASES.has(c.phase)) throw new ProtocolError("contact needs id and a known phase");
    for (const k of ["touch_m", "pointer_m", "touch_px", "pointer_px"]) {
      if (!isVec(c[k])) throw new ProtocolError(`contact ${k} must be [x, y]`);
    }
    if (!isNum(c.tension) || typeof c.material !== "string") throw new ProtocolError("contact needs tension and material");
    if (c.string !== undefined && !(isNum(c.string.length_px) && isVec(c.string.dir))) {
      throw new ProtocolError("contact string needs length_px and dir");
    }
  }
  return msg;
}

function describe(f) {
  const head = `tick ${f.tick} t ${f.t.toFixed(3)} ${f.device}`;
  if (!f.contacts.length) return `${head} (no contact)`;
  return `${head} ` + f.contacts.map((c) => {
    const s = c.string ? ` string ${c.string.length_px.toFixed(1)} px` : "";
    return `#${c.id} ${c.phase} pointer (${c.pointer_px[0].toFixed(1)}, ${c.pointer_px[1].toFixed(1)}) px T ${c.tension.toExponential(2)} N${s} ${c.material}`;
  }).join(" | ");
}

async function snapshot(endpoint) {
  const req = new Request({ receiveTimeout: 2000, sendTimeout: 2000, linger: 0 });
  req.connect(endpoint);
  try {
    await req.send(encode({ v: SCHEMA_VERSION, op: "snapshot" }));
    const [reply] = await req.receive();
    const msg = decode(reply);
    checkVersion(msg);
    if (msg.ok !== true) throw new ProtocolError(`snapshot refused: ${msg.error}`);
    return msg;
  } finally {
    req.close();
  }
}

async function main() {
  const opts = parseArgs(process.argv.slice(2));
  const out = (f) => process.stdout.write((opts.json ? JSON.stringify(f) : describe(f)) + "\n");
  const wanted = (f) => opts.devices.length === 0 || opts.devices.includes(f.device);
  const sub = new Subscriber({ linger: 0, receiveHighWaterMark: 10000 });
  sub.connect(opts.endpoint);
  if (opts.devices.length) for (const d of opts.devices) sub.subscribe(`frame.${d}`);
  else sub.subscribe("frame.");

  let printed = 0;
  let bad = 0;
  let lastTick = -Infinity; // the clone pattern: drop frames the snapshot covered
  const done = () => printed >= opts.count;
  if (opts.control) {
    const snap = await snapshot(opts.control);
    lastTick = snap.tick;
    for (const f of Object.values(snap.frames || {})) {
      if (done()) break;
      const frame = checkFrame(f);
      if (wanted(frame)) { out(frame); printed++; }
    }
  }
  const ending = () => { sub.close(); };
  process.on("SIGINT", ending);
  process.on("SIGTERM", ending);
  try {
    while (!done()) {
      const parts = await sub.receive();
      const topic = parts[0].toString("utf8");
      const payload = parts[parts.length - 1];
      let frame;
      try {
        if (parts.length < 2 || !topic.startsWith("frame.")) throw new ProtocolError(`unexpected topic ${topic}`);
        frame = checkFrame(decode(payload));
      } catch (err) {
        if (err.fatal) throw err;
        bad++;
        console.error(`subscribe.mjs: skipped a bad message (${bad} so far): ${err.message}`);
        continue;
      }
      if (frame.tick <= lastTick) {
        if (frame.tick > lastTick - 10000) continue; // already in the snapshot
        lastTick = -Infinity; // far older: the daemon restarted, ticks begin again
      }
      if (wanted(frame)) { out(frame); printed++; }
    }
  } catch (err) {
    if (sub.closed) return; // SIGINT / SIGTERM
    throw err;
  } finally {
    if (!sub.closed) sub.close();
  }
}

main().catch((err) => {
  console.error(`subscribe.mjs: error: ${err.message}`);
  process.exit(err instanceof ProtocolError ? 2 : 1);
});
