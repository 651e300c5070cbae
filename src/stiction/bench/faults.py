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
- a **device storm** (where umockdev is installed: _device_storm.py) plugs a
  mocked evdev pen in, plays a stroke, and unplugs it mid-stroke, again and
  again, through the daemon's own udev monitor and python-evdev reads;
- an **accountant** subscribes from the start and follows every device's
  chain of frames (tick, prev_tick): no frame lost, every plug read, every
  unplug closed with an "up";

and a bare sleeping loop runs in its own process on the same grid, so late
ticks can be told from the machine's own stalls. Printed and written to
faults.{json,txt}: inputs tried, crashes (the daemon exited), hangs (a
request unanswered within 5 s, or ticks not advancing for 2 s), late ticks
of the daemon against the bare loop, the daemon's RSS at the start and the
end, and the frames accounted for. Targets: 0 crashes, 0 hangs, RSS growth
under 5%, every frame accounted for, every plug read and every unplug closed.
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
from stiction.bench._device_storm import STORM_NAME, DeviceStorm, storm_problem
from stiction.bench._support import results_dir
from stiction.drivers.evdev.source import slug

REPLY_DEADLINE_S = 5.0
STORM_DEVICE = slug(STORM_NAME)  # the storm pen's name in frames
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
    """Reads every frame and follows each device's chain of ticks.

    A frame names the tick of its device's previous frame (`prev_tick`), so a
    frame lost anywhere, a device's absence included, shows as a break in the
    chain. The storm pen's sessions are counted too: its first frame after a
    closing "up" starts one.
    """

    def __init__(self, ctx: zmq.Context[Any], pub: str) -> None:
        super().__init__(daemon=True)
        self.sock = ctx.socket(zmq.SUB)
        self.sock.rcvhwm = 0
        self.sock.connect(pub)
        self.sock.setsockopt(zmq.SUBSCRIBE, protocol.TOPIC_FRAME)
        self.stop = threading.Event()
        self.frames: dict[str, int] = {}
        self.first: dict[str, int] = {}
        self.last: dict[str, int] = {}
        self.gaps = 0
        self.storm_sessions = 0
        self.storm_ups = 0
        self._storm_open = False

    def run(self) -> None:
        while not self.stop.is_set():
            if not self.sock.poll(100):
                continue
            _, payload = self.sock.recv_multipart()
            frame = protocol.decode(payload)
            self.account(frame)
        self.sock.close(0)

    def account(self, frame: dict[str, Any]) -> None:
        dev, tick = str(frame["device"]), int(frame["tick"])
        last = self.last.get(dev)
        if last is not None and frame.get("prev_tick") != last:
            self.gaps += 1
        self.first.setdefault(dev, tick)
        self.last[dev] = tick
        self.frames[dev] = self.frames.get(dev, 0) + 1
        if dev == STORM_DEVICE:
            if not self._storm_open:
                self.storm_sessions += 1
                self._storm_open = True
            if any(c.get("phase") == "up" for c in frame.get("contacts", ())):
                self.storm_ups += 1
                self._storm_open = False

    @property
    def total(self) -> int:
        return sum(self.frames.values())


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


def _synthetic_name(acc: Accountant) -> str | None:
    names = [d for d in acc.frames if d != STORM_DEVICE]
    return names[0] if names else None


def run(seconds: float, tmp: Path, seed: int = 1, storm: bool = True) -> dict[str, Any]:
    from stiction.bench.daemon import BareProcess

    pub, ctl = f"ipc://{tmp}/pub", f"ipc://{tmp}/ctl"
    scene = tmp / "scene.toml"
    scene.write_text(GOOD_SCENE)
    log_path = tmp / "stictiond.log"
    log_file = log_path.open("w")  # a file, not a pipe: an undrained pipe would block its logging
    why_no_storm = storm_problem() if storm else "not asked for (--no-storm)"
    devices = DeviceStorm(tmp, seconds, seed) if why_no_storm is None else None
    argv = [sys.executable, "-m", "stiction.daemon.main", "--device", "synthetic:demo",
            "--scene", str(scene), "--pub", pub, "--control", ctl, "--keepalive", "0"]  # fmt: skip
    if devices is not None:
        argv += ["--device", f"name:{STORM_NAME}"]  # waits for it, reopens it on every plug
    proc = subprocess.Popen(
        argv, stderr=log_file, text=True, env=devices.daemon_env() if devices else None
    )
    ctx = zmq.Context()
    c = Counters()
    storm_summary: dict[str, Any] = {}
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
        if devices is not None:
            devices.go()
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
        if devices is not None:
            storm_summary = devices.stop()
            time.sleep(0.5)  # the last unplug's closing frame
        crashed = proc.poll() is not None
        end = None if crashed else _ask(ctx, ctl, "stats")
        rss1 = 0 if crashed else _rss_kib(proc.pid)
        synthetic = _synthetic_name(accountant)
        if end is not None and synthetic is not None:  # catch up with the last tick stats saw
            last = int(end["stats"]["ticks"]) - 1
            for _ in range(300):
                if accountant.last.get(synthetic, -1) >= last:
                    break
                time.sleep(0.1)
        accountant.stop.set()
        accountant.join(10)
        bare_late = bare.result()[1]
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        if devices is not None:
            devices.close()
        log_file.close()
        err = log_path.read_text(errors="replace")
        ctx.term()
    v = c.values
    stats_end = end["stats"] if end else {}
    synthetic = _synthetic_name(accountant)
    span = (
        accountant.last[synthetic] - accountant.first[synthetic] + 1 if synthetic is not None else 0
    )
    storm_frames = accountant.frames.get(STORM_DEVICE, 0)
    plugs = int(storm_summary.get("plugs", 0))
    return {
        "seconds": seconds,
        "inputs_tried": v.get("requests", 0)
        + v.get("reloads", 0)
        + v.get("subscribers_flooded", 0)
        + plugs,
        "control_requests": v.get("requests", 0),
        "refused": v.get("refused", 0),
        "sighup_reloads": v.get("reloads", 0),
        "subscribers_flooded": v.get("subscribers_flooded", 0),
        "device_storm": None
        if devices is None
        else {
            "plugs": plugs,
            "unplugs": int(storm_summary.get("unplugs", 0)),
            "controller_error": storm_summary.get("error", "no answer"),
            "sessions_seen": accountant.storm_sessions,
            "closing_ups_seen": accountant.storm_ups,
            "frames": storm_frames,
        },
        "device_storm_skipped": why_no_storm,
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
        "frames_accounted": accountant.total,
        # the synthetic pen ticks every period; the storm pen's frames are chained by prev_tick
        "frames_published": span + storm_frames,
        "tick_gaps": accountant.gaps,
        "control_errors_counted": int(stats_end.get("control_errors", 0)),
        "scene_errors_counted": int(stats_end.get("scene_errors", 0)),
    }


def _targets(r: dict[str, Any]) -> dict[str, bool | None]:
    """None: not run here (the device storm without umockdev)."""
    growth = r["rss_growth_pct"]
    storm = r["device_storm"]
    return {
        "0 crashes": r["crashes"] == 0,
        "0 hangs": r["hangs"] == 0,
        "RSS growth < 5%": growth is not None and growth < 5.0,
        "every frame accounted for": r["tick_gaps"] == 0
        and 0 < r["frames_accounted"] == r["frames_published"],
        "every plug read, every unplug closed": None
        if storm is None
        else storm["controller_error"] is None
        and 0 < storm["plugs"] == storm["sessions_seen"]
        and storm["unplugs"] == storm["closing_ups_seen"],
    }


def _verdict(ok: bool | None) -> str:
    return "NOT RUN" if ok is None else "PASS" if ok else "FAIL"


def _storm_line(r: dict[str, Any]) -> str:
    storm = r["device_storm"]
    if storm is None:
        return f"device storm           not run: {r['device_storm_skipped']}"
    error = f"; controller error: {storm['controller_error']}" if storm["controller_error"] else ""
    return (
        f"device storm           {storm['plugs']:>8}  plugs ({storm['sessions_seen']} read), "
        f"{storm['unplugs']} unplugs ({storm['closing_ups_seen']} closed with up), "
        f"{storm['frames']} frames{error}"
    )


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="stiction bench faults", description=__doc__)
    ap.add_argument("--seconds", type=float, default=60.0, help="how long the attack lasts")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    ap.add_argument(
        "--no-storm", action="store_true", help="leave out the umockdev device unplug/replug storm"
    )
    args = ap.parse_args(argv)
    if not args.seconds > 0:
        ap.error("--seconds must be > 0")
    with tempfile.TemporaryDirectory(prefix="sf-") as tmp:
        r = run(args.seconds, Path(tmp), storm=not args.no_storm)
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
        _storm_line(r),
        f"crashes                {r['crashes']:>8}",
        f"hangs                  {r['hangs']:>8}  {r['hang_kinds']}",
        f"tracebacks in its log  {r['tracebacks_logged']:>8}",
        f"late ticks             {r['late_ticks_daemon']:>8}  (bare loop beside it: "
        f"{r['late_ticks_bare']}); deadlines skipped: {r['skipped_deadlines_daemon']}",
        f"RSS start / end (KiB)  {r['rss_start_kib']:>8} / {r['rss_end_kib']}  ({growth_text})",
        f"frames accounted for   {r['frames_accounted']:>8}  of {r['frames_published']} "
        f"published while subscribed (tick gaps: {r['tick_gaps']})",
        "",
        "targets: " + ", ".join(f"{k} {_verdict(ok)}" for k, ok in targets.items()),
    ]
    table = "\n".join(lines)
    out = results_dir()
    (out / "faults.txt").write_text(table + "\n")
    (out / "faults.json").write_text(json.dumps(r, indent=2) + "\n")
    print(json.dumps(r) if args.json else table)
    return 0
