"""`stiction record`: subscribe, spool as it goes, write one .npz at the end.

The metadata that makes a recording interpretable later (the scene, the
material parameters, the devices) is asked of the control endpoint once at
start; a daemon without one still gets recorded, and the file says so.

A session is never held in memory whole, and a killed recorder does not lose
it: received messages are kept a chunk at a time (``spool.CHUNK`` messages,
or ``spool.FLUSH_EVERY`` second, whichever fills first) and each chunk is
appended, as columns plus the raw messages, to ``<out>.partial`` and synced.
A clean stop (count, seconds, idle, Ctrl-C, SIGTERM) streams the .npz from
that spool, chunk by chunk, and deletes it. After a SIGKILL, an OOM kill or
a power cut the spool holds everything up to the last flushed chunk, and

    stiction record --recover trial.npz.partial

writes it as ``trial.npz`` in the same format (``meta["recovered"]`` says so);
the next ``stiction record --out trial.npz`` also recovers a leftover spool on
its own, into ``trial.recovered.npz``, before it starts. Why one append-only
file of checksummed chunk records, and how assembly streams: spool.py.
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
from stiction.clients import control, spool
from stiction.clients.curve import CurveKeys
from stiction.clients.messages import SceneMessage
from stiction.clients.stream import SubscriberStats
from stiction.clients.subscriber import Subscriber
from stiction.errors import ProtocolError, RecordingError, StictionError

log = logging.getLogger("stiction.clients.record")


@dataclass(frozen=True)
class RecordResult:
    path: Path
    frames: int
    contacts: int
    scenes: int
    bad: int
    recovered: Path | None = None
    """Where a spool left by an earlier, killed recorder of the same file went."""


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


class NothingRecorded(RecordingError):
    """The session ended before a single frame arrived: no file is written."""


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
    chunk: int = spool.CHUNK,
    flush_every: float = spool.FLUSH_EVERY,
    fsync: bool = True,
    force: bool = False,
) -> RecordResult:
    """Record until ``count`` frames, ``seconds``, ``idle`` seconds of silence
    after the first frame, ``stop`` being set, or Ctrl-C; then write ``out``.
    Raises NothingRecorded, writing nothing, when not one frame arrived.

    While recording, messages go to the spool ``out.partial`` every ``chunk``
    messages or ``flush_every`` seconds (module doc); a spool left there by a
    recorder that was killed is first recovered into ``<stem>.recovered.npz``.
    """
    out = Path(out)
    if out.suffix != ".npz":
        raise RecordingError(f"{out}: recordings are numpy .npz files; name it *.npz")
    if out.exists() and not force:
        raise RecordingError(f"{out} exists; pass --force to replace it (nothing was recorded)")
    if chunk < 1 or not flush_every > 0:
        raise RecordingError(f"chunk ({chunk}) and flush_every ({flush_every}) must be positive")
    recovered = recover_leftover(out)
    writer = spool.SpoolWriter.create(spool.spool_path(out), fsync=fsync)
    t0 = last_t = last_flush = time.monotonic()
    sub: Subscriber | None = None
    stats = SubscriberStats()
    stopped_by: StictionError | None = None
    try:
        meta = fetch_metadata(control_endpoint, curve=curve)
        reachable = "control_error" not in meta
        meta.update(
            endpoint=endpoint,
            devices_filter=list(devices) if devices else None,
            started_utc=datetime.now(UTC).isoformat(),
            stiction_version=__version__,
        )
        writer.write_meta(meta)
        t0 = last_t = last_flush = time.monotonic()
        end = None if seconds is None else t0 + seconds
        sub = Subscriber(
            endpoint,
            devices=devices,
            kinds=("frame", "scene"),
            control=control_endpoint if reachable else None,
            curve=curve,
        )
        while count is None or writer.frames < count:
            if stop is not None and stop.is_set():
                break
            now = time.monotonic()
            if end is not None and now >= end:
                break
            wait = 0.2 if end is None else min(0.2, end - now)
            msg = sub.recv(wait)
            now = time.monotonic()
            if msg is not None:
                last_t = now
                if isinstance(msg, SceneMessage):
                    topic = protocol.TOPIC_SCENE
                else:
                    topic = protocol.frame_topic(msg.device)
                writer.add(topic, protocol.encode(msg.wire), last_t - t0, msg)
            if writer.pending >= chunk or (writer.pending and now - last_flush >= flush_every):
                writer.flush(asdict(sub.stats), now - t0)
                last_flush = now
                log.debug("spooled %d frames to %s", writer.flushed_frames, writer.path)
            if msg is None and idle is not None and writer.frames and now - last_t >= idle:
                break
    except KeyboardInterrupt:
        pass  # Ctrl-C ends a recording; what was received is still written
    except StictionError as exc:
        if writer.broken:
            writer.close()  # cannot write on: the spool keeps what was flushed
            raise
        if not writer.frames and not writer.scenes:
            writer.discard()  # e.g. a bad endpoint: nothing to keep
            raise
        stopped_by = exc  # e.g. a newer schema from the daemon: write what came before
    except BaseException:
        writer.close()  # a bug: the spool keeps what was flushed; the traceback says why
        raise
    finally:
        if sub is not None:
            stats = sub.stats
            sub.close()
    if not writer.frames and stopped_by is None:
        writer.discard()  # a file without a frame helps nobody, and would look like a session
        from stiction.clients.diagnose import why_silent

        _, why = why_silent(endpoint, control_endpoint, curve=curve, wanted=devices)
        raise NothingRecorded(
            f"no frame arrived in {time.monotonic() - t0:.1f} s, so nothing was written to "
            f"{out}: {why}"
        )
    try:
        summary = writer.finish(out, asdict(stats), time.monotonic() - t0)
    except BaseException:
        writer.close()
        raise
    if stopped_by is not None:
        raise RecordingError(
            f"{stopped_by}; recording stopped, {summary.frames} frames received before "
            f"were written to {out}"
        ) from stopped_by
    return RecordResult(
        path=out,
        frames=summary.frames,
        contacts=summary.contacts,
        scenes=summary.scene_count,
        bad=stats.bad,
        recovered=recovered,
    )


def recover_leftover(out: Path) -> Path | None:
    """A spool that a killed recorder of ``out`` left: recover it into
    ``<stem>.recovered.npz`` (``-2``, ``-3`` ... if taken), so the new session
    can spool in its place and nothing of the old one is lost. Returns where
    it went, or None when there was none (or it held no message)."""
    path = spool.spool_path(out)
    if not path.exists():
        return None
    target = out.with_name(f"{out.stem}.recovered.npz")
    n = 1
    while target.exists():
        n += 1
        target = out.with_name(f"{out.stem}.recovered-{n}.npz")
    summary = spool.recover(path, target, keep_empty=False)
    if summary.output is None:
        log.warning("%s: a killed recorder left it without a single message; deleted", path)
        return None
    log.warning(
        "%s: a killed recorder left it; recovered %d frames into %s",
        path,
        summary.frames,
        summary.output,
    )
    return summary.output


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
    if result.recovered is not None:
        print(
            f"stiction record: recovered the session a killed recorder left to {result.recovered}",
            file=sys.stderr,
        )
    print(
        f"stiction record: wrote {result.frames} frames ({result.contacts} contacts, "
        f"{result.scenes} scene messages) to {result.path}"
        + (f"; skipped {result.bad} malformed" if result.bad else ""),
        file=sys.stderr,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m stiction.clients.record --recover SPOOL [--out FILE.npz]``."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m stiction.clients.record",
        description="Turn the spool that a killed `stiction record` left (FILE.npz.partial) "
        "into the recording it was writing. Everything up to the last flushed chunk is in it.",
    )
    parser.add_argument("--recover", metavar="SPOOL", required=True, help="a *.npz.partial spool")
    parser.add_argument("--out", help="recording to write (default: SPOOL without .partial)")
    parser.add_argument("--force", action="store_true", help="replace --out if it exists")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    return recover_spool(args.recover, args.out, args.force)


def recover_spool(path: str, out: str | None, force: bool) -> int:
    """`stiction record --recover`: one line saying what was recovered, or the error."""
    try:
        summary = spool.recover(path, out, overwrite=force)
    except StictionError as exc:
        print(f"stiction record: error: {exc}", file=sys.stderr)
        return 2
    print(
        f"stiction record: recovered {summary.frames} frames ({summary.contacts} contacts, "
        f"{summary.scene_count} scene messages"
        + ("" if summary.final else "; the chunk not yet flushed when it stopped is lost")
        + f") from {path} to {summary.output}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
