"""`stiction listen`: print what a subscriber receives, for people and for pipes."""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from typing import TextIO

from stiction.clients.curve import CurveKeys
from stiction.clients.messages import Frame, Message
from stiction.clients.subscriber import Subscriber


def describe(msg: Message) -> str:
    """One human-readable line per message: the numbers a person checks first."""
    if not isinstance(msg, Frame):
        scene = msg.scene
        effects = ", ".join(scene.get("effects", []))
        regions = len(scene.get("regions", []))
        name = scene.get("name", "?")
        return f"scene {name!r} (tick {msg.tick}): {regions} regions, effects {effects}"
    head = f"tick {msg.tick:>7}  t {msg.t:10.3f}  {msg.device}"
    if not msg.contacts:
        return f"{head}  (no contact)"
    parts = []
    for c in msg.contacts:
        s = "" if c.string is None else f"  string {c.string.length_px:6.1f} px"
        parts.append(
            f"#{c.id} {c.phase:<5} pointer ({c.pointer_px[0]:7.1f}, {c.pointer_px[1]:7.1f}) px"
            f"  touch ({c.touch_px[0]:7.1f}, {c.touch_px[1]:7.1f}) px"
            f"  T {c.tension:.3g} N{s}  {c.material}"
        )
    return f"{head}  " + " | ".join(parts)


def listen(
    endpoint: str,
    *,
    as_json: bool = False,
    count: int | None = None,
    seconds: float | None = None,
    devices: Sequence[str] | None = None,
    scenes: bool = False,
    out: TextIO | None = None,
    curve: CurveKeys | None = None,
    control: str | None = None,
) -> int:
    """Print frames until ``count`` frames or ``seconds`` pass (or forever).

    Returns 1, with a hint on stderr, when ``seconds`` passed without any
    frame: a script can tell "daemon silent" from "daemon talked". With a
    ``control`` endpoint the hint says which: no daemon, no device yet, or
    a daemon that publishes elsewhere.
    """
    out = out or sys.stdout
    kinds = ("frame", "scene") if scenes else ("frame",)
    n = 0
    end = None if seconds is None else time.monotonic() + seconds
    with Subscriber(endpoint, devices=devices, kinds=kinds, curve=curve) as sub:
        while count is None or n < count:
            wait = None if end is None else end - time.monotonic()
            if wait is not None and wait <= 0:
                break
            msg = sub.recv(wait)
            if msg is None:
                continue
            print(msg.to_json() if as_json else describe(msg), file=out, flush=True)
            if isinstance(msg, Frame):
                n += 1
        stats = sub.stats
    if stats.bad:
        print(
            f"stiction listen: skipped {stats.bad} malformed message(s); last: {stats.last_error}",
            file=sys.stderr,
        )
    if n == 0 and seconds is not None and (count is None or count > 0):
        from stiction.clients.diagnose import why_silent

        _, why = why_silent(endpoint, control, curve=curve, wanted=devices)
        print(f"stiction listen: no frames in {seconds:g} s: {why}", file=sys.stderr)
        return 1
    return 0
