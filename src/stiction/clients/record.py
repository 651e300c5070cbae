"""`stiction record`: subscribe, keep everything, write one .npz at the end.

The metadata that makes a recording interpretable later (the scene, the
material parameters, the devices) is asked of the control endpoint once at
start; a daemon without one still gets recorded, and the file says so.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from types import FrameType
from typing import Any

from stiction import __version__, protocol
from stiction.clients import control, recording
from stiction.clients.curve import CurveKeys
from stiction.clients.messages import Frame, SceneMessage
from stiction.clients.stream import SubscriberStats
from stiction.clients.subscriber import Subscriber
from stiction.errors import ProtocolError, RecordingError

log = logging.getLogger("stiction.clients.record")


@dataclass(frozen=True)
class RecordResult:
    path: Path
    frames: int
    contacts: int
    scenes: int
    bad: int


def fetch_metadata(
    control_endpoint: str | None, timeout: float = 1.0, curve: CurveKeys | None = None
) -> dict[str, Any]:
    """Scene, parameters and devices from the daemon, or why they are missing."""
    if control_endpoint is None:
        return {"control": None, "control_error": "no control endpoint given"}
    meta: dict[str, Any] = {"control": control_endpoint}
    try:
        meta["daemon"] = control.request(control_endpoint, "ping", timeout=timeout, curve=curve)
        scene = control.request(control_endpoint, "get_scene", timeout=timeout, curve=curve)
        meta["scene"] = scene.get("scene")
        meta["scene_toml"] = scene.get("toml")
        meta["params"] = control.request(
            control_endpoint, "get_params", timeout=timeout, curve=curve
        )
        devices = control.request(control_endpoint, "devices", timeout=timeout, curve=curve)
        meta["devices"] = devices.get("devices")
    except (control.ControlUnavailable, ProtocolError) as exc:
        meta["control_error"] = str(exc)
        log.warning("recording without daemon metadata: %s", exc)
    for reply_key in ("daemon", "params"):
        if isinstance(meta.get(reply_key), dict):
            meta[reply_key] = {k: v for k, v in meta[reply_key].items() if k not in ("v", "ok")}
    return meta


def record(
    endpoint: str,
    out: str | Path,
    *,
    control_endpoint: str | None = None,
    count: int | None = None,
    seconds: float | None = None,
    idle: float | None = None,
    devices: Sequence[str] | None = None,
    stop: threading.Event | None = None,
    curve: CurveKeys | None = None,
) -> RecordResult:
    """Record until ``count`` frames, ``seconds``, ``idle`` seconds of silence
    after the first frame, ``stop`` being set, or Ctrl-C; then write ``out``."""
    out = Path(out)
    if out.suffix != ".npz":
        raise RecordingError(f"{out}: recordings are numpy .npz files; name it *.npz")
    meta = fetch_metadata(control_endpoint, curve=curve)
    reachable = "control_error" not in meta
    meta.update(
        endpoint=endpoint,
        devices_filter=list(devices) if devices else None,
        started_utc=datetime.now(UTC).isoformat(),
        stiction_version=__version__,
    )
    messages: list[tuple[bytes, bytes, float]] = []
    frames: list[Frame] = []
    scenes: list[dict[str, Any]] = []
    t0 = last_t = time.monotonic()
    end = None if seconds is None else t0 + seconds
    sub: Subscriber | None = None
    try:
        sub = Subscriber(
            endpoint,
            devices=devices,
            kinds=("frame", "scene"),
            control=control_endpoint if reachable else None,
            curve=curve,
        )
        while count is None or len(frames) < count:
            if stop is not None and stop.is_set():
                break
            now = time.monotonic()
            if end is not None and now >= end:
                break
            wait = 0.2 if end is None else min(0.2, end - now)
            msg = sub.recv(wait)
            if msg is None:
                if idle is not None and frames and time.monotonic() - last_t >= idle:
                    break
                continue
            last_t = time.monotonic()
            if isinstance(msg, SceneMessage):
                topic = protocol.TOPIC_SCENE
                scenes.append({"tick": msg.tick, "scene": msg.scene})
            else:
                topic = protocol.frame_topic(msg.device)
                frames.append(msg)
            messages.append((topic, protocol.encode(msg.wire), last_t - t0))
    except KeyboardInterrupt:
        pass  # Ctrl-C ends a recording; what was received is still written
    finally:
        stats = sub.stats if sub is not None else SubscriberStats()
        if sub is not None:
            sub.close()
    if meta.get("scene") is None and scenes:
        meta["scene"] = scenes[0]["scene"]
    meta["scene_changes"] = scenes
    meta["subscriber_stats"] = asdict(stats)
    meta["duration_s"] = time.monotonic() - t0
    path = recording.write(out, messages, frames, meta)
    return RecordResult(
        path=path,
        frames=len(frames),
        contacts=sum(len(f.contacts) for f in frames),
        scenes=len(scenes),
        bad=stats.bad,
    )


@contextlib.contextmanager
def stop_on_signals() -> Iterator[threading.Event]:
    """Ctrl-C and SIGTERM end a recording at the next message boundary, wherever
    the recorder is (also while it still asks the daemon for metadata); the
    file is written either way. The previous handlers come back afterwards."""
    stop = threading.Event()

    def handler(signum: int, frame: FrameType | None) -> None:
        stop.set()

    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGTERM, signal.SIGINT)}
    try:
        yield stop
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


def report(result: RecordResult) -> None:
    print(
        f"stiction record: wrote {result.frames} frames ({result.contacts} contacts, "
        f"{result.scenes} scene messages) to {result.path}"
        + (f"; skipped {result.bad} malformed" if result.bad else ""),
        file=sys.stderr,
    )
