"""Typed, immutable views of what the daemon publishes.

The wire form (protocol.FrameWire, a plain map) is what travels and what JSON
tools print; these classes are what Python code wants to hold: attribute
access, tuples instead of lists, and the optional string as None rather than a
missing key. The validated wire map stays attached (``Frame.wire``) so keys a
newer daemon adds are never lost on the way through a client.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

from stiction import protocol
from stiction.errors import ProtocolError

Vec = tuple[float, float]


def _vec(value: list[float], where: str) -> Vec:
    x, y = float(value[0]), float(value[1])
    # protocol.validate_frame checks the shape of vectors but (as of schema 1)
    # not their finiteness; a NaN pointer would poison every renderer downstream.
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ProtocolError(f"{where} must be finite, got [{x}, {y}]")
    return (x, y)


@dataclass(frozen=True, slots=True)
class StringState:
    """The virtual string: ``length_px`` pixels from the pointer along ``dir``."""

    length_px: float
    dir: Vec


@dataclass(frozen=True, slots=True)
class Contact:
    id: int
    phase: protocol.Phase
    touch_m: Vec
    pointer_m: Vec
    touch_px: Vec
    pointer_px: Vec
    tension: float
    material: str
    string: StringState | None

    @property
    def string_end_px(self) -> Vec | None:
        """Where a renderer draws the free end of the string, or None without one."""
        if self.string is None:
            return None
        px, py = self.pointer_px
        dx, dy = self.string.dir
        n = self.string.length_px
        return (px + dx * n, py + dy * n)


@dataclass(frozen=True, slots=True)
class Frame:
    """One device's state at one tick."""

    v: int
    tick: int
    t: float
    t_input: float | None
    device: str
    contacts: tuple[Contact, ...]
    wire: protocol.FrameWire
    prev_tick: int | None = None
    """Tick of this device's previous frame (-1: the first); None from a
    daemon that does not say. Ticks between it and `tick` had nothing new."""

    kind = "frame"

    @classmethod
    def from_wire(cls, wire: protocol.FrameWire) -> Frame:
        """Build from a map that protocol.validate_frame has accepted."""
        contacts = []
        for i, c in enumerate(wire["contacts"]):
            s = c.get("string")
            w = f"contacts[{i}]"
            contacts.append(
                Contact(
                    id=int(c["id"]),
                    phase=c["phase"],
                    touch_m=_vec(c["touch_m"], f"{w}.touch_m"),
                    pointer_m=_vec(c["pointer_m"], f"{w}.pointer_m"),
                    touch_px=_vec(c["touch_px"], f"{w}.touch_px"),
                    pointer_px=_vec(c["pointer_px"], f"{w}.pointer_px"),
                    tension=float(c["tension"]),
                    material=c["material"],
                    string=None
                    if s is None
                    else StringState(float(s["length_px"]), _vec(s["dir"], f"{w}.string.dir")),
                )
            )
        t_input = wire.get("t_input")
        return cls(
            v=int(wire["v"]),
            tick=int(wire["tick"]),
            t=float(wire["t"]),
            t_input=None if t_input is None else float(t_input),
            device=wire["device"],
            contacts=tuple(contacts),
            wire=wire,
            prev_tick=wire.get("prev_tick"),
        )

    def to_json(self) -> str:
        """The wire frame as one line of JSON (what ``stiction listen --json`` prints)."""
        return wire_to_json(self.wire)


@dataclass(frozen=True, slots=True)
class SceneMessage:
    """The active scene (docs/protocol.md "Scene"), published on topic ``scene``
    at start and whenever it changes; ``tick`` is the last tick sent before it
    took effect. Renderers draw ``scene``; unknown keys pass through untouched."""

    v: int
    tick: int
    wire: protocol.SceneMessageWire

    kind = "scene"

    @property
    def scene(self) -> protocol.SceneWire:
        return self.wire["scene"]

    @classmethod
    def from_wire(cls, wire: protocol.SceneMessageWire) -> SceneMessage:
        return cls(v=int(wire["v"]), tick=int(wire["tick"]), wire=wire)

    def to_json(self) -> str:
        return wire_to_json(self.wire)


Message = Frame | SceneMessage


def _json_default(obj: Any) -> Any:
    if isinstance(obj, bytes):
        return obj.hex()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _finite(obj: Any) -> Any:
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


def wire_to_json(wire: Any) -> str:
    """Render a decoded wire map as compact JSON; the one msgpack->JSON rule.

    JSON has no NaN or infinity: the validated keys are always finite, but a
    key this client does not know may not be, and becomes null rather than
    invalid JSON (which browsers refuse to parse). Bytes, which the schema
    does not use, become hex rather than failing.
    """
    try:
        return json.dumps(wire, separators=(",", ":"), default=_json_default, allow_nan=False)
    except ValueError:
        return json.dumps(
            _finite(wire), separators=(",", ":"), default=_json_default, allow_nan=False
        )


def is_newer_schema(message: dict[str, Any]) -> bool:
    v = message.get("v")
    return isinstance(v, int) and not isinstance(v, bool) and v > protocol.SCHEMA_VERSION


def parse_message(topic: bytes, payload: bytes) -> Message:
    """Decode one published message by its topic.

    Raises ProtocolError for anything malformed; the message of a frame from a
    newer schema says so and names both versions (see protocol.check_version).
    """
    message = protocol.decode(payload)
    protocol.check_version(message)
    if topic.startswith(protocol.TOPIC_FRAME):
        frame = Frame.from_wire(protocol.validate_frame(message))
        expected = topic[len(protocol.TOPIC_FRAME) :].decode("utf-8", "replace")
        if frame.device != expected:
            shown = topic.decode("utf-8", "replace")
            raise ProtocolError(f"frame for device {frame.device!r} arrived on topic {shown!r}")
        return frame
    if topic == protocol.TOPIC_SCENE:
        return SceneMessage.from_wire(protocol.validate_scene_message(message))
    raise ProtocolError(f"unknown topic {topic[:64]!r}")
