"""Issue 13 through a real daemon: set_params reaches a contact already on a material."""

from __future__ import annotations

import math
import threading
from typing import Any

import msgpack
import zmq
from daemon_support import ListSource, Runner, make_daemon, request, subscribe

from stiction import protocol
from stiction.drivers.sample import PenSample

STRETCH = 0.0005
"""Metres: well inside the stick disc at the default scene's mu_s (6.9 mm)."""


def _tension_until(sub: zmq.Socket[Any], want: float, limit: int = 2000) -> list[float]:
    """Tensions of the pressed contact, frame by frame, until one equals `want` (or give up)."""
    seen: list[float] = []
    for _ in range(limit):
        if not sub.poll(5000):
            break
        topic, payload = sub.recv_multipart()
        if not topic.startswith(protocol.TOPIC_FRAME):
            continue
        for c in msgpack.unpackb(payload)["contacts"]:
            if c["phase"] == "stick":
                seen.append(c["tension"])
        if seen and math.isclose(seen[-1], want, rel_tol=1e-6):
            break
    return seen


def test_set_params_changes_the_tension_of_a_stuck_contact(endpoints: tuple[str, str]) -> None:
    gate = threading.Event()
    press = [
        PenSample(t=i * 0.004, x=0.05 + STRETCH * min(i, 10) / 10, y=0.05, tip=True)
        for i in range(30)
    ]
    d = make_daemon(endpoints, {"pen": ListSource(press, gate=gate)})
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    try:
        with Runner(d):
            before = _tension_until(sub, 0.1 * STRETCH)
            assert before and math.isclose(before[-1], 0.1 * STRETCH, rel_tol=1e-6)
            reply = request(ctx, endpoints[1], protocol.make_request("set_params", k=0.2))
            assert reply["ok"] and reply["materials"]["standard"]["k"] == 0.2
            after = _tension_until(sub, 0.2 * STRETCH)
            # Held still and stuck: only the new k can double the tension.
            assert after and math.isclose(after[-1], 0.2 * STRETCH, rel_tol=1e-6), after[-5:]
            gate.set()
    finally:
        gate.set()
        sub.close()
