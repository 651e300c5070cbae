"""What a subscriber does with each received message, independent of I/O.

Shared by the blocking Subscriber and the asyncio AsyncSubscriber so both
filter, count, conflate and survive bad input identically. Nothing here
touches a socket.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from stiction import protocol
from stiction.clients.messages import Frame, Message, SceneMessage, is_newer_schema, parse_message
from stiction.errors import ProtocolError

log = logging.getLogger("stiction.clients")

KINDS = ("frame", "scene")

RESTART_BACKSTEP = 10_000
"""A frame this many ticks older than the snapshot cannot be a late arrival
from before the snapshot (the queues are not that deep): it is a restarted
daemon counting from zero again, and is delivered."""


@dataclass(slots=True)
class SubscriberStats:
    """Counters a long-running client can report; nothing is dropped silently."""

    received: int = 0
    """Messages taken off the socket, good or bad."""
    frames: int = 0
    """Frames delivered to the caller."""
    scenes: int = 0
    bad: int = 0
    """Malformed messages skipped (see last_error)."""
    conflated: int = 0
    """Messages replaced, unread and undecoded, by a newer one on the same topic
    (one stream per device, plus the scene) when conflating."""
    missed: int = 0
    """Frames never seen (slow reader, reconnect): the ticks between the last
    frame seen of a device and the frame before this one (``prev_tick``). A
    device that was away (unplugged, then back) sent no frames in between, and
    its first frame back names its last one, so that gap is not counted. (From
    a daemon that sends no ``prev_tick``, every gap in a device's ticks counts.)"""
    restarts: int = 0
    """Times a device's ticks went backwards: the daemon restarted."""
    disconnects: int = 0
    """Connections to a daemon lost (it stopped, crashed, or its machine vanished)."""
    reconnects: int = 0
    """Connections (re-)established after a loss; frames continue without the
    gap being counted as missed, as the daemon may have restarted."""
    stale: int = 0
    """Frames dropped because the snapshot already covered them (clone pattern)."""
    last_error: str | None = None


def normalise_kinds(kinds: Iterable[str]) -> tuple[str, ...]:
    out = tuple(dict.fromkeys(kinds))
    for k in out:
        if k not in KINDS:
            raise ProtocolError(f"unknown message kind {k!r}; known: {', '.join(KINDS)}")
    if not out:
        raise ProtocolError("subscribe to at least one kind of message")
    return out


def subscriptions(kinds: Sequence[str], devices: Sequence[str] | None) -> list[bytes]:
    """The topic prefixes to subscribe to: filtering happens in the publisher."""
    topics: list[bytes] = []
    if "frame" in kinds:
        if devices is None:
            topics.append(protocol.TOPIC_FRAME)
        else:
            topics.extend(protocol.frame_topic(d) for d in devices)
    if "scene" in kinds:
        topics.append(protocol.TOPIC_SCENE)
    return topics


class StreamState:
    """Turns raw multipart messages into delivered Messages, or into counts."""

    def __init__(self, kinds: Sequence[str], devices: Sequence[str] | None, conflate: bool) -> None:
        self.kinds = tuple(kinds)
        self.devices = None if devices is None else frozenset(devices)
        self.conflate = conflate
        self.stats = SubscriberStats()
        self._last_tick: dict[str, int] = {}
        self._snapshot_tick: dict[str, int] = {}
        self._snapshot_default: int | None = None
        self._synced: set[str] = set()
        self._scene_after: int | None = None
        self._pending: dict[bytes, tuple[list[bytes], int]] = {}
        self._replaced = 0
        self._lost = False
        self._bad_logged = 0

    # -- per message -----------------------------------------------------------

    def accept(self, parts: list[bytes]) -> Message | None:
        """Parse, check and filter one message; None when it is not delivered.

        A newer schema raises ProtocolError: every following frame would be
        unreadable too, so the caller must hear about it rather than see a
        silent stream. Anything else malformed is counted and skipped.
        """
        self.stats.received += 1
        if len(parts) < 2:
            self._bad(f"message with {len(parts)} part(s), expected [topic, payload]")
            return None
        topic, payload = parts[0], parts[-1]
        try:
            msg = parse_message(topic, payload)
        except ProtocolError as exc:
            if self._newer(payload):
                self.stats.bad += 1
                self.stats.last_error = str(exc)
                raise
            self._bad(str(exc))
            return None
        if isinstance(msg, SceneMessage):
            if "scene" not in self.kinds:
                return None
            if self._scene_after is not None:
                # The snapshot carried the scene in force at its tick; older
                # scene messages still in flight would step back in time.
                if msg.tick < self._scene_after:
                    self.stats.stale += 1
                    return None
                self._scene_after = None
            self.stats.scenes += 1
            return msg
        if "frame" not in self.kinds or (
            self.devices is not None and msg.device not in self.devices
        ):
            return None
        if not self._in_sequence(msg):
            return None
        self.stats.frames += 1
        return msg

    def _newer(self, payload: bytes) -> bool:
        try:
            return is_newer_schema(protocol.decode(payload))
        except ProtocolError:
            return False

    def _bad(self, why: str) -> None:
        self.stats.bad += 1
        self.stats.last_error = why
        # Log the 1st, 10th, 100th ... so a flood of garbage cannot flood the log.
        if self.stats.bad >= 10**self._bad_logged:
            self._bad_logged += 1
            log.warning("skipped a bad message (%d so far): %s", self.stats.bad, why)

    def _in_sequence(self, frame: Frame) -> bool:
        dev = frame.device
        if dev not in self._synced:
            snap = self._snapshot_tick.get(dev, self._snapshot_default)
            if snap is not None and snap - RESTART_BACKSTEP < frame.tick <= snap:
                self.stats.stale += 1
                return False
            self._synced.add(dev)
        last = self._last_tick.get(dev)
        if last is not None:
            if frame.tick <= last:
                self.stats.restarts += 1
                log.info("device %s restarted its ticks (%d after %d)", dev, frame.tick, last)
            else:
                # Ticks in which the device sent nothing (it was away) are not missing.
                prev = frame.prev_tick if frame.prev_tick is not None else frame.tick - 1
                if prev > last:
                    # Frames conflation replaced were received, not missed.
                    self.stats.missed += max(0, prev - last - self._replaced)
        self._last_tick[dev] = frame.tick
        return True

    # -- connection events (from the socket monitor) ---------------------------

    def connection_event(self, event: int) -> None:
        """Feed ZMQ_EVENT_CONNECTED / DISCONNECTED: after a reconnect the tick
        sequence may start anywhere (a restarted daemon that ran a while before
        ZeroMQ's backoff let us in), so it is re-learnt rather than compared."""
        import zmq

        if event == zmq.EVENT_DISCONNECTED:
            self.stats.disconnects += 1
            self._lost = True
        elif event == zmq.EVENT_CONNECTED and self._lost:
            self._lost = False
            self.stats.reconnects += 1
            self._last_tick.clear()

    # -- clone pattern ---------------------------------------------------------

    def snapshot_messages(self, reply: dict[str, Any]) -> list[Message]:
        """Messages to deliver first from a ``snapshot`` reply, and the ticks to drop.

        Reads the documented keys: ``tick`` (the last tick published, one
        number or a map device -> tick), ``frames`` (the latest frame per
        device) and ``scene``. Keys it does not find are simply not used.
        """
        out: list[Message] = []
        tick = reply.get("tick")
        scene = reply.get("scene")
        if "scene" in self.kinds and isinstance(scene, dict):
            snap_tick = tick if isinstance(tick, int) and not isinstance(tick, bool) else -1
            try:
                wire = protocol.validate_scene_message(protocol.scene_message(scene, snap_tick))  # type: ignore[arg-type]
            except ProtocolError as exc:
                self._bad(f"snapshot scene: {exc}")
            else:
                out.append(SceneMessage.from_wire(wire))
                self.stats.scenes += 1
                self._scene_after = snap_tick
        frames = reply.get("frames")
        if isinstance(frames, dict):
            frames = list(frames.values())
        ticks: dict[str, int] = {}
        if isinstance(frames, list):
            for wire_frame in frames:
                try:
                    frame = Frame.from_wire(protocol.validate_frame(wire_frame))
                except (ProtocolError, TypeError, AttributeError) as exc:
                    self._bad(f"snapshot frame: {exc}")
                    continue
                ticks[frame.device] = frame.tick
                if "frame" in self.kinds and (self.devices is None or frame.device in self.devices):
                    out.append(frame)
                    self.stats.frames += 1
                    self._last_tick[frame.device] = frame.tick
        if isinstance(tick, int) and not isinstance(tick, bool):
            self._snapshot_default = tick
        elif isinstance(tick, dict):
            for dev, t in tick.items():
                if isinstance(dev, str) and isinstance(t, int) and not isinstance(t, bool):
                    ticks[dev] = max(t, ticks.get(dev, t))
        self._snapshot_tick.update(ticks)
        self._synced.clear()
        return out

    # -- conflation ------------------------------------------------------------

    def keep_latest(self, parts: list[bytes]) -> None:
        """Hold a raw message, replacing an unread one on the same topic.

        Nothing is decoded here: a frame that a newer one replaces before the
        caller reads it is never looked at, which is what makes draining a
        long queue cheap. The one delivered is checked in full by `accept`.
        """
        topic = parts[0] if parts else b""
        prev = self._pending.pop(topic, None)  # re-insert: order follows arrival
        self._pending[topic] = (parts, 0 if prev is None else prev[1] + 1)

    def pop_pending(self) -> Message | None:
        """The oldest held message that passes `accept`, or None."""
        while self._pending:
            topic = next(iter(self._pending))
            parts, replaced = self._pending.pop(topic)
            self.stats.received += replaced
            self.stats.conflated += replaced
            self._replaced = replaced
            msg = self.accept(parts)
            self._replaced = 0
            if msg is not None:
                return msg
        return None
