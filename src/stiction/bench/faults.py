"""A daemon under attack: hostile requests, bad reloads, subscriber abuse, for a set time.

Run as ``stiction bench faults [--seconds S] [--json]``. One real stictiond
(synthetic pen, the demo scene, ipc:// sockets in a private folder) runs
while, in parallel threads,

- a **control attacker** sends malformed msgpack, unknown ops, wrong types,
  requests from a newer schema, 2 MiB requests, set_scene with /dev/zero, a
  FIFO, a directory, TOML nested 5,000 deep, wrong types and huge numbers,
  and set_params with absurd values, each on a REQ socket with a deadline;
- a **reloader** rewrites the daemon's scene file with broken and good
  versions and sends SIGHUP;
- a **subscriber abuser** keeps one subscriber that never reads, connects
  and drops subscribers, and floods in bursts of 50 new ones;
- an **accountant** subscribes from the start and checks that the frames of
  the one device come with consecutive tick numbers (no frame lost);

and a bare sleeping loop runs in its own process on the same grid, so late
ticks can be told from the machine's own stalls. Printed and written to
faults.{json,txt}: inputs tried, crashes (the daemon exited), hangs (a
request unanswered within 5 s, or ticks not advancing for 2 s), late ticks
of the daemon against the bare loop, the daemon's RSS at the start and the
end, and the frames accounted for. Targets: 0 crashes, 0 hangs, RSS growth
under 5%, every frame accounted for.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import msgpack
import zmq

from stiction import protocol
from stiction.bench._support import results_dir

REPLY_DEADLINE_S = 5.0
GOOD_SCENE = '[scene]\nname = "good"\noutside = "m"\n[materials.m]\nmu_s = 0.7\nmu_k = 0.1\n'
BAD_SCENES = [
    "a = " + "[" * 5000 + "]" * 5000 + "\n",
    '[[regions]]\nshape = ["rect"]\n',
    "[materials.m]\nmu_s = 1e308\nmu_k = 0.1\n",
    "[scene]\ndisplay = [99999999999999999999, 1]\n",
    "not toml at all [[[\n",
]


def _rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


class Counters:
    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.values: dict[str, int] = {}

    def add(self, key: str, n: int = 1) -> None:
        with self.lock:
            self.values[key] = self.values.get(key, 0) + n


def _hostile_requests(tmp: Path, rng: random.Random) -> list[bytes]:
    fifo = tmp / "scene.fifo"
    if not fifo.exists():
        os.mkfifo(fifo)
    req = protocol.make_request
    fixed = [
        b"\xc1 not msgpack",
        msgpack.packb([1, 2, 3]),
        msgpack.packb({"v": 1, "op": "format_disk"}),
        msgpack.packb({"v": 99, "op": "ping"}),
        msgpack.packb({"op": "ping"}),
        msgpack.packb({"v": 1, "op": "set_params", "k": "soft"}),
        msgpack.packb({"v": 1, "op": "set_params", "k": 2**63}),
        msgpack.packb({"v": 1, "op": "set_params", "mu_s": float("nan")}),
        msgpack.packb({"v": 1, "op": "set_scene", "toml": 5}),
        req("set_scene", path="/dev/zero"),
        req("set_scene", path=str(fifo)),
        req("set_scene", path=str(tmp)),
        req("set_scene", toml="#" * (2 << 20)),
        *(req("set_scene", toml=t) for t in BAD_SCENES),
    ]
    fixed.append(bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 64))))
    return fixed


def attack_control(ctx: zmq.Context[Any], ctl: str, tmp: Path, stop: threading.Event,
                   c: Counters, seed: int) -> None:  # fmt: skip
    rng = random.Random(seed)
    while not stop.is_set():
        for payload in _hostile_requests(tmp, rng):
            if stop.is_set():
                return
            sock = ctx.socket(zmq.REQ)
            sock.linger = 0
            sock.sndtimeo = int(REPLY_DEADLINE_S * 1000)
            sock.connect(ctl)
            try:
                sock.send(payload)
                c.add("requests")
                if not sock.poll(int(REPLY_DEADLINE_S * 1000)):
                    c.add("hangs")
                    c.add("unanswered_requests")
                    continue
                reply = protocol.decode(sock.recv())
                c.add("refused" if not reply.get("ok") else "accepted")
            except zmq.ZMQError:
                c.add("hangs")
            finally:
                sock.close(0)


def reload_storm(proc: subprocess.Popen[str], scene: Path, stop: threading.Event,
                 c: Counters) -> None:  # fmt: skip
    i = 0
    while not stop.wait(0.2):
        scene.write_text(BAD_SCENES[i % len(BAD_SCENES)] if i % 3 else GOOD_SCENE)
        if proc.poll() is not None:
            return
        proc.send_signal(signal.SIGHUP)
        c.add("reloads")
        i += 1


def abuse_subscribers(ctx: zmq.Context[Any], pub: str, stop: threading.Event,
                      c: Counters) -> None:  # fmt: skip
    lazy = ctx.socket(zmq.SUB)  # subscribed, never reads
    lazy.rcvhwm = 10
    lazy.linger = 0
    lazy.connect(pub)
    lazy.setsockopt(zmq.SUBSCRIBE, b"")
    try:
        while not stop.wait(0.5):
            burst = []
            for _ in range(50):
                s = ctx.socket(zmq.SUB)
                s.linger = 0
                s.connect(pub)
                s.setsockopt(zmq.SUBSCRIBE, b"")
                burst.append(s)
            c.add("subscribers_flooded", len(burst))
            for s in burst:
                s.close(0)
    finally:
        lazy.close(0)


class Accountant(threading.Thread):
    """Reads every frame; counts gaps in the tick sequence of the one device."""

    def __init__(self, ctx: zmq.Context[Any], pub: str) -> None:
        super().__init__(daemon=True)
        self.sock = ctx.socket(zmq.SUB)
        self.sock.rcvhwm = 0
        self.sock.connect(pub)
        self.sock.setsockopt(zmq.SUBSCRIBE, protocol.TOPIC_FRAME)
        self.stop = threading.Event()
        self.frames = 0
        self.gaps = 0
        self.first_tick: int | None = None
        self.last_tick: int | None = None

    def run(self) -> None:
        while not self.stop.is_set():
            if not self.sock.poll(100):
                continue
            _, payload = self.sock.recv_multipart()
            tick = int(protocol.decode(payload)["tick"])
            if self.first_tick is None:
                self.first_tick = tick
            if self.last_tick is not None and tick != self.last_tick + 1:
                self.gaps += 1
            self.last_tick = tick
            self.frames += 1
        self.sock.close(0)


def _ask(ctx: zmq.Context[Any], ctl: str, op: str) -> dict[str, Any] | None:
    sock = ctx.socket(zmq.REQ)
    sock.linger = 0
    sock.connect(ctl)
    try:
        sock.send(protocol.make_request(op))  # type: ignore[arg-type]
        if not sock.poll(int(REPLY_DEADLINE_S * 1000)):
            return None
        return dict(protocol.decode(sock.recv()))
    finally:
        sock.close(0)


def run(seconds: float, tmp: Path, seed: int = 1) -> dict[str, Any]:
    from stiction.bench.daemon import BareProcess

    pub, ctl = f"ipc://{tmp}/pub", f"ipc://{tmp}/ctl"
    scene = tmp / "scene.toml"
    scene.write_text(GOOD_SCENE)
    log_path = tmp / "stictiond.log"
    log_file = log_path.open("w")  # a file, not a pipe: an undrained pipe would block its logging
    proc = subprocess.Popen(
        [sys.executable, "-m", "stiction.daemon.main", "--device", "synthetic:demo",
         "--scene", str(scene), "--pub", pub, "--control", ctl, "--keepalive", "0"],
        stderr=log_file, text=True,
    )  # fmt: skip
    ctx = zmq.Context()
    c = Counters()
    try:
        first = None
        for _ in range(60):
            first = _ask(ctx, ctl, "stats")
            if first is not None or proc.poll() is not None:
                break
        if first is None:
            raise RuntimeError("stictiond did not start")
        accountant = Accountant(ctx, pub)
        accountant.start()
        time.sleep(2.0)  # settle: the compiled tick loaded, the first frames out
        first = _ask(ctx, ctl, "stats") or first
        rss0 = _rss_kib(proc.pid)
        late0 = int(first["stats"]["late_ticks"])
        skipped0 = int(first["stats"]["skipped_deadlines"])
        bare = BareProcess(seconds, 100.0, str(tmp / "bare"), None)
        bare.go(time.monotonic() + 0.05)
        stop = threading.Event()
        workers = [
            threading.Thread(target=attack_control, args=(ctx, ctl, tmp, stop, c, seed)),
            threading.Thread(target=reload_storm, args=(proc, scene, stop, c)),
            threading.Thread(target=abuse_subscribers, args=(ctx, pub, stop, c)),
        ]
        for w in workers:
            w.start()
        t_end = time.monotonic() + seconds
        last_ticks, last_change = -1, time.monotonic()
        while time.monotonic() < t_end and proc.poll() is None:
            stats = _ask(ctx, ctl, "stats")
            if stats is None:
                c.add("hangs")
                c.add("stats_unanswered")
                continue
            ticks = int(stats["stats"]["ticks"])
            now = time.monotonic()
            if ticks != last_ticks:
                last_ticks, last_change = ticks, now
            elif now - last_change > 2.0:
                c.add("hangs")
                c.add("ticks_stopped")
                last_change = now
            time.sleep(0.25)
        stop.set()
        for w in workers:
            w.join(30)
        crashed = proc.poll() is not None
        end = None if crashed else _ask(ctx, ctl, "stats")
        rss1 = 0 if crashed else _rss_kib(proc.pid)
        if end is not None:  # let the accountant catch up with the last tick stats saw
            last = int(end["stats"]["ticks"]) - 1
            for _ in range(300):
                if accountant.last_tick is not None and accountant.last_tick >= last:
                    break
                time.sleep(0.1)
        accountant.stop.set()
        accountant.join(10)
        _, bare_late, _, _ = bare.result()
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log_file.close()
        err = log_path.read_text(errors="replace")
        ctx.term()
    v = c.values
    stats_end = end["stats"] if end else {}
    return {
        "seconds": seconds,
        "inputs_tried": v.get("requests", 0)
        + v.get("reloads", 0)
        + v.get("subscribers_flooded", 0),
        "control_requests": v.get("requests", 0),
        "refused": v.get("refused", 0),
        "sighup_reloads": v.get("reloads", 0),
        "subscribers_flooded": v.get("subscribers_flooded", 0),
        "crashes": int(crashed or proc.returncode not in (0, None)),
        "hangs": v.get("hangs", 0),
        "tracebacks_logged": err.count("Traceback"),
        "late_ticks_daemon": int(stats_end.get("late_ticks", 0)) - late0,
        "late_ticks_bare": bare_late,
        "skipped_deadlines_daemon": int(stats_end.get("skipped_deadlines", 0)) - skipped0,
        "hang_kinds": {
            k: v.get(k, 0) for k in ("unanswered_requests", "stats_unanswered", "ticks_stopped")
        },
        "rss_start_kib": rss0,
        "rss_end_kib": rss1,
        "rss_growth_pct": (rss1 - rss0) / rss0 * 100 if rss0 and rss1 else None,
        "frames_accounted": accountant.frames,
        "frames_published": (
            accountant.last_tick - accountant.first_tick + 1
            if accountant.last_tick is not None and accountant.first_tick is not None
            else 0
        ),
        "tick_gaps": accountant.gaps,
        "control_errors_counted": int(stats_end.get("control_errors", 0)),
        "scene_errors_counted": int(stats_end.get("scene_errors", 0)),
    }


def _targets(r: dict[str, Any]) -> dict[str, bool]:
    growth = r["rss_growth_pct"]
    return {
        "0 crashes": r["crashes"] == 0,
        "0 hangs": r["hangs"] == 0,
        "RSS growth < 5%": growth is not None and growth < 5.0,
        "every frame accounted for": r["tick_gaps"] == 0
        and 0 < r["frames_accounted"] == r["frames_published"],
    }


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="stiction bench faults", description=__doc__)
    ap.add_argument("--seconds", type=float, default=60.0, help="how long the attack lasts")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    if not args.seconds > 0:
        ap.error("--seconds must be > 0")
    with tempfile.TemporaryDirectory(prefix="sf-") as tmp:
        r = run(args.seconds, Path(tmp))
    targets = _targets(r)
    r["targets"] = targets
    load = os.getloadavg()[0]
    growth = r["rss_growth_pct"]
    growth_text = "n/a" if growth is None else f"{growth:+.2f}%"
    lines = [
        f"stictiond under attack for {r['seconds']:g} s (load average {load:.2f} on "
        f"{os.cpu_count()} CPUs)",
        "",
        f"inputs tried           {r['inputs_tried']:>8}  (control {r['control_requests']}, "
        f"SIGHUP {r['sighup_reloads']}, subscribers {r['subscribers_flooded']})",
        f"refused in words       {r['refused']:>8}",
        f"crashes                {r['crashes']:>8}",
        f"hangs                  {r['hangs']:>8}  {r['hang_kinds']}",
        f"tracebacks in its log  {r['tracebacks_logged']:>8}",
        f"late ticks             {r['late_ticks_daemon']:>8}  (bare loop beside it: "
        f"{r['late_ticks_bare']}); deadlines skipped: {r['skipped_deadlines_daemon']}",
        f"RSS start / end (KiB)  {r['rss_start_kib']:>8} / {r['rss_end_kib']}  ({growth_text})",
        f"frames accounted for   {r['frames_accounted']:>8}  of {r['frames_published']} "
        f"published while subscribed (tick gaps: {r['tick_gaps']})",
        "",
        "targets: " + ", ".join(f"{k} {'PASS' if ok else 'FAIL'}" for k, ok in targets.items()),
    ]
    table = "\n".join(lines)
    out = results_dir()
    (out / "faults.txt").write_text(table + "\n")
    (out / "faults.json").write_text(json.dumps(r, indent=2) + "\n")
    print(json.dumps(r) if args.json else table)
    return 0
