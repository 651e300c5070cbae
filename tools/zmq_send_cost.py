#!/usr/bin/env python3
"""What one ZeroMQ send costs the sending thread at a deadline, cold and warmed.

Usage: python tools/zmq_send_cost.py [--ticks N] [--subscribers N] [--rounds N]

The daemon's prepared tick (docs/daemon.md, "Issue 15") spends most of its
CPU time at the deadline in one `send_multipart` on its XPUB socket. This
tool times that send alone, the way the loop reaches it: sleep in 0.5 ms
steps until 0.3 ms before a 10 ms deadline, spin to it, send a frame-sized
message to N subscriber processes over loopback TCP, then send it again at
once. Three ways of spending the spin are interleaved, round by round:

- none: nothing before the deadline (the send path is cold after the sleep);
- void: one send of the message through a PUB socket with no peer at the
  start of the spin (what the daemon's preparation does, Publisher.warm_payload);
- inproc: the same through a PUSH socket to a PULL drained by another
  thread (a send that reaches a pipe and wakes a reader).

It prints, per way, the sending thread's CPU time (`time.thread_time`) for
the first send (the deadline's) and the second (the same path, hot), p50,
p90 and p99 in microseconds, and the first send's p50 over the second's.
This is the evidence for the send figures in docs/daemon.md; it is not a
benchmark (nothing is compared against a target), and its figures belong to
the machine it runs on.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import threading
import time
from typing import Any

import zmq

WAYS = ("none", "void", "inproc")
PERIOD_S = 0.010
SPIN_S = 0.0003
TOPIC = b"frame.synthetic-demo"
PAYLOAD = b"\x87" + b"x" * 179  # about the size of a one-contact frame

SUBSCRIBER = """
import sys, zmq
ctx = zmq.Context()
s = ctx.socket(zmq.SUB)
s.rcvtimeo = 3000
s.connect(sys.argv[1])
s.subscribe(b"frame")
try:
    while True:
        s.recv_multipart()
except zmq.Again:
    pass
"""


def _quantiles(xs: list[float]) -> tuple[float, float, float]:
    v = sorted(xs)
    n = len(v)
    return v[n // 2] * 1e6, v[int(0.9 * n)] * 1e6, v[min(int(0.99 * n), n - 1)] * 1e6


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="tools/zmq_send_cost.py", description=__doc__)
    parser.add_argument("--ticks", type=int, default=300, help="deadlines per way and round")
    parser.add_argument("--subscribers", type=int, default=10, help="subscriber processes")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of the three ways")
    opts = parser.parse_args(argv)

    ctx: zmq.Context[Any] = zmq.Context()
    pub = ctx.socket(zmq.XPUB)
    pub.setsockopt(zmq.XPUB_VERBOSE, 1)
    pub.linger = 0
    pub.bind("tcp://127.0.0.1:*")
    endpoint = pub.last_endpoint.decode()
    void = ctx.socket(zmq.PUB)
    void.linger = 0
    pull = ctx.socket(zmq.PULL)
    pull.linger = 0
    pull.bind("inproc://warm")
    push = ctx.socket(zmq.PUSH)
    push.linger = 0
    push.connect("inproc://warm")
    stop = threading.Event()

    def drain() -> None:
        poller = zmq.Poller()
        poller.register(pull, zmq.POLLIN)
        while not stop.is_set():
            if poller.poll(50):
                pull.recv_multipart()

    drainer = threading.Thread(target=drain, daemon=True)
    drainer.start()
    subs = [
        subprocess.Popen([sys.executable, "-c", SUBSCRIBER, endpoint])
        for _ in range(opts.subscribers)
    ]
    try:
        joined = 0
        while joined < opts.subscribers:
            if not pub.poll(10_000):
                print("subscribers did not arrive", file=sys.stderr)
                return 1
            joined += pub.recv()[:1] == b"\x01"
        first: dict[str, list[float]] = {w: [] for w in WAYS}
        second: dict[str, list[float]] = {w: [] for w in WAYS}
        for _ in range(opts.rounds):
            for way in WAYS:
                for i in range(opts.ticks + 10):
                    deadline = time.monotonic() + PERIOD_S
                    while time.monotonic() < deadline - SPIN_S:
                        time.sleep(0.0005)
                    if way == "void":
                        void.send_multipart((TOPIC, PAYLOAD), flags=zmq.DONTWAIT)
                    elif way == "inproc":
                        push.send_multipart((TOPIC, PAYLOAD), flags=zmq.DONTWAIT)
                    while time.monotonic() < deadline:
                        pass
                    c0 = time.thread_time()
                    pub.send_multipart((TOPIC, PAYLOAD), flags=zmq.DONTWAIT)
                    c1 = time.thread_time()
                    pub.send_multipart((TOPIC, PAYLOAD), flags=zmq.DONTWAIT)
                    c2 = time.thread_time()
                    if i >= 10:  # the first few after switching ways are left out
                        first[way].append(c1 - c0)
                        second[way].append(c2 - c1)
        print(
            f"{'way':8}{'first p50':>11}{'p90':>8}{'p99':>8}"
            f"{'second p50':>12}{'p90':>8}{'p99':>8}{'first/second':>14}"
        )
        for way in WAYS:
            f = _quantiles(first[way])
            s = _quantiles(second[way])
            print(
                f"{way:8}{f[0]:11.1f}{f[1]:8.1f}{f[2]:8.1f}"
                f"{s[0]:12.1f}{s[1]:8.1f}{s[2]:8.1f}{f[0] / s[0]:13.1f}x"
            )
        print(
            f"(us of the sending thread's CPU time; {opts.subscribers} subscribers, "
            f"{opts.rounds} x {opts.ticks} deadlines per way)"
        )
        return 0
    finally:
        stop.set()
        drainer.join()
        for p in subs:
            p.kill()
            p.wait()
        for s in (pub, void, push, pull):
            s.close(linger=0)
        ctx.term()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
