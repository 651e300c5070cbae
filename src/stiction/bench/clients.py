"""What the client side costs per frame, against the naive way in the same run.

Run as ``stiction bench clients [--frames N] [--pages P] [--json]``.

Reading: N frames (two contacts with strings, as the demo publishes) are
queued on an inproc SUB socket, then consumed by (a) the naive loop a user
would write (recv_multipart + msgpack.unpackb, no checks), (b) the same plus
protocol.decode_frame's validation, (c) stiction.clients.Subscriber (checks,
finite vectors, typed frames, tick bookkeeping), (d) Subscriber with
conflation (draining the queue, keeping the newest per device).

Transcoding for the web bridge: P pages watching; the naive bridge turns the
frame into JSON once per page, the real one once per frame.

Both tables are microseconds per frame, min of 5 repeats; written to
clients.{txt,json} in the results folder (--save: bench/results/).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import msgpack
import zmq

from stiction import protocol
from stiction.bench._support import results_dir
from stiction.clients import Frame, Subscriber
from stiction.clients.messages import wire_to_json


def sample_frame(tick: int) -> dict[str, Any]:
    contacts = []
    for cid in range(2):
        contacts.append(
            {
                "id": cid,
                "phase": "stick",
                "touch_m": [0.0412 + cid * 0.01, 0.0213],
                "pointer_m": [0.0401 + cid * 0.01, 0.0213],
                "touch_px": [812.3 + cid * 100, 420.0],
                "pointer_px": [790.6 + cid * 100, 420.0],
                "tension": 1.1e-4,
                "material": "rubber",
                "string": {"length_px": 21.0, "dir": [0.9987, 0.0512]},
            }
        )
    return {
        "v": 1,
        "kind": "frame",
        "tick": tick,
        "t": 47.11 + tick * 0.01,
        "t_input": 47.105 + tick * 0.01,
        "device": "synthetic:demo",
        "contacts": contacts,
    }


def fill(ctx: zmq.Context[Any], endpoint: str, n: int) -> zmq.Socket[Any]:
    """A bound XPUB with n frames already sent to one subscriber (inproc: queued)."""
    pub: zmq.Socket[Any] = ctx.socket(zmq.XPUB)
    pub.setsockopt(zmq.SNDHWM, 0)
    pub.bind(endpoint)
    return pub


def time_reader(n: int, make: Callable[[zmq.Context[Any], str], Callable[[], int]]) -> float:
    """Seconds to consume n queued frames with the reader ``make`` builds."""
    ctx: zmq.Context[Any] = zmq.Context()
    endpoint = "inproc://bench"
    pub = fill(ctx, endpoint, n)
    read = make(ctx, endpoint)
    pub.recv()  # the subscription arrived: everything sent now is queued for the reader
    topic = protocol.frame_topic("synthetic:demo")
    payloads = [protocol.encode(sample_frame(i)) for i in range(n)]
    for p in payloads:
        pub.send_multipart([topic, p])
    t0 = time.perf_counter()
    got = read()
    dt = time.perf_counter() - t0
    pub.close(0)
    ctx.term()
    if got <= 0:
        raise RuntimeError("reader got nothing")
    return dt


def naive(ctx: zmq.Context[Any], endpoint: str, n: int, validate: bool) -> Callable[[], int]:
    sub: zmq.Socket[Any] = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.RCVHWM, 0)
    sub.setsockopt(zmq.SUBSCRIBE, b"frame.")
    sub.connect(endpoint)

    def read() -> int:
        for _ in range(n):
            _topic, payload = sub.recv_multipart()
            if validate:
                protocol.decode_frame(payload)
            else:
                msgpack.unpackb(payload)
        sub.close(0)
        return n

    return read


def subscriber(ctx: zmq.Context[Any], endpoint: str, n: int, conflate: bool) -> Callable[[], int]:
    sub = Subscriber(endpoint, context=ctx, conflate=conflate, hwm=0)

    def read() -> int:
        got = 0
        if conflate:
            while sub.recv(timeout=0) is not None:
                got += 1
            sub.close()
            return got
        for _ in range(n):
            if isinstance(sub.recv(), Frame):
                got += 1
        sub.close()
        return got

    return read


def best(fn: Callable[[], float], repeats: int = 5) -> float:
    return min(fn() for _ in range(repeats))


def main(argv: Sequence[str]) -> int:
    ap = argparse.ArgumentParser(prog="stiction bench clients")
    ap.add_argument("--frames", type=int, default=20_000)
    ap.add_argument("--pages", type=int, default=10)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(list(argv))
    n = args.frames
    rows: list[tuple[str, float]] = []
    rows.append(
        (
            "naive: recv + msgpack.unpackb",
            best(lambda: time_reader(n, lambda c, e: naive(c, e, n, False))),
        )
    )
    rows.append(
        (
            "recv + protocol.decode_frame",
            best(lambda: time_reader(n, lambda c, e: naive(c, e, n, True))),
        )
    )
    rows.append(
        (
            "Subscriber.recv (typed frames)",
            best(lambda: time_reader(n, lambda c, e: subscriber(c, e, n, False))),
        )
    )
    rows.append(
        (
            "Subscriber conflate (drain to newest)",
            best(lambda: time_reader(n, lambda c, e: subscriber(c, e, n, True))),
        )
    )
    read = [(name, dt / n * 1e6) for name, dt in rows]

    frames = [sample_frame(i) for i in range(2000)]
    pages = args.pages

    def per_page() -> float:
        t0 = time.perf_counter()
        for f in frames:
            for _ in range(pages):
                json.dumps(f)
        return time.perf_counter() - t0

    def once() -> float:
        t0 = time.perf_counter()
        for f in frames:
            wire_to_json(f)
        return time.perf_counter() - t0

    trans = [
        (f"naive: json.dumps per page ({pages} pages)", best(per_page) / len(frames) * 1e6),
        ("bridge: wire_to_json once per frame", best(once) / len(frames) * 1e6),
    ]
    base = read[0][1]
    lines = [f"reading {n} queued frames (2 contacts each), us per frame, min of 5"]
    lines.append(f"{'reader':<42}{'us/frame':>10}{'x naive':>10}")
    lines += [f"{name:<42}{us:>10.2f}{us / base:>10.2f}" for name, us in read]
    lines += ["", f"web bridge transcoding, us per frame, {pages} pages watching"]
    lines += [f"{name:<42}{us:>10.2f}{us / trans[0][1]:>10.2f}" for name, us in trans]
    table = "\n".join(lines)
    result = {"read_us_per_frame": dict(read), "transcode_us_per_frame": dict(trans)}
    (results_dir() / "clients.txt").write_text(table + "\n")
    (results_dir() / "clients.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result) if args.json else table)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
