"""The wire schema, in one place: imported by the daemon and by every client.

Everything a process on the other end of a socket may see is defined here:
topics, the frame map, control requests and replies, and the version rule.
docs/protocol.md is the prose form of this module; change both together.

Messages are msgpack maps (string keys, floats as float64, vectors as
2-element arrays). Published messages are ZeroMQ multipart ``[topic, payload]``
so a subscriber can filter on the topic prefix without decoding anything.
"""

from __future__ import annotations

import functools
import ipaddress
import math
import reprlib
import threading
from collections.abc import Mapping
from typing import Any, Literal, NotRequired, TypedDict, cast

import msgpack

from stiction.errors import ProtocolError

_brief = reprlib.Repr()
_brief.maxstring = 60
_brief.maxother = 60

SCHEMA_VERSION = 1
"""Bumped only for changes that would make an old client misread a frame.
Adding keys is not such a change; clients ignore keys they do not know."""

DEFAULT_PUB = "tcp://127.0.0.1:5556"
DEFAULT_CONTROL = "tcp://127.0.0.1:5557"

TOPIC_FRAME = b"frame."
"""Frame topics are ``frame.<device>``: subscribe to ``frame.`` for all devices."""
TOPIC_SCENE = b"scene"
"""Published whenever the active scene changes (and on start)."""

MAX_MESSAGE_BYTES = 1 << 20
"""Larger payloads are refused before decoding: a frame is a few hundred bytes."""

Phase = Literal["stick", "slip", "hover", "up"]
PHASES: tuple[Phase, ...] = ("stick", "slip", "hover", "up")


class StringWire(TypedDict):
    length_px: float
    dir: list[float]


class ContactWire(TypedDict):
    id: int
    phase: Phase
    touch_m: list[float]
    pointer_m: list[float]
    touch_px: list[float]
    pointer_px: list[float]
    tension: float
    material: str
    string: NotRequired[StringWire]


class FrameWire(TypedDict):
    v: int
    kind: Literal["frame"]
    tick: int
    prev_tick: NotRequired[int]
    t: float
    t_input: float | None
    device: str
    contacts: list[ContactWire]


def contact(
    id: int,
    phase: Phase,
    touch_m: list[float],
    pointer_m: list[float],
    touch_px: list[float],
    pointer_px: list[float],
    tension: float,
    material: str,
    string: StringWire | None = None,
) -> ContactWire:
    """One contact of a frame, keys in the documented order; `string` only when
    the scene has the string effect. (The compiled pipeline writes its
    contacts in this order itself; a test checks they match this builder.)"""
    c: ContactWire = {
        "id": id,
        "phase": phase,
        "touch_m": touch_m,
        "pointer_m": pointer_m,
        "touch_px": touch_px,
        "pointer_px": pointer_px,
        "tension": tension,
        "material": material,
    }
    if string is not None:
        c["string"] = string
    return c


def frame(
    tick: int,
    prev_tick: int,
    t: float,
    t_input: float | None,
    device: str,
    contacts: list[ContactWire],
) -> FrameWire:
    """The frame a daemon publishes for one device at one tick."""
    return {
        "v": SCHEMA_VERSION,
        "kind": "frame",
        "tick": tick,
        "prev_tick": prev_tick,
        "t": t,
        "t_input": t_input,
        "device": device,
        "contacts": contacts,
    }


@functools.lru_cache(maxsize=256)
def frame_topic(device: str) -> bytes:
    """The topic of a device's frames; device names are UTF-8.

    Cached: the loop asks for every device's topic every tick, and the
    answer never changes for a name."""
    return TOPIC_FRAME + device.encode("utf-8")


class _Packers(threading.local):
    """One msgpack Packer per thread, kept for every message that thread encodes.

    `msgpack.packb` builds a new Packer per call, and a Packer allocates a
    256 KiB buffer: glibc serves that with mmap and frees it with munmap,
    so every frame cost a fresh mapping, its page faults and, in a process
    with threads on other CPUs, a TLB shoot-down. A kept Packer reuses one
    buffer (a Packer is not thread-safe, hence one per thread).
    `stiction bench daemon` times both ways, interleaved, on a frame packed
    right after a 5 ms sleep as a tick packs it ("encoding a frame"
    in bench/results/daemon.txt)."""

    def __init__(self) -> None:
        # autoreset (the default): pack() returns the bytes and empties the
        # buffer, also when packing raises, so a failed message leaves nothing behind
        self.packer = msgpack.Packer(use_bin_type=True)


_packers = _Packers()


def encode(message: Mapping[str, Any]) -> bytes:
    """Pack one message; a value msgpack cannot carry is a programming error
    in the sender, reported as ProtocolError so a daemon can log and go on."""
    try:
        return cast(bytes, _packers.packer.pack(message))
    except (TypeError, ValueError, OverflowError) as exc:
        raise ProtocolError(f"cannot encode message: {exc}") from exc


def decode(payload: bytes) -> dict[str, Any]:
    """Unpack one message into a map, refusing anything that is not one."""
    if len(payload) > MAX_MESSAGE_BYTES:
        raise ProtocolError(f"message of {len(payload)} bytes exceeds {MAX_MESSAGE_BYTES}")
    try:
        obj = msgpack.unpackb(payload, raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises several unrelated types for garbage
        raise ProtocolError(f"not a msgpack message: {exc}") from exc
    if not isinstance(obj, dict):
        raise ProtocolError(f"message is a {type(obj).__name__}, expected a map")
    return obj


def check_version(message: Mapping[str, Any]) -> None:
    """Reject a message from a newer schema rather than misread it."""
    v = message.get("v")
    if not isinstance(v, int) or isinstance(v, bool):
        raise ProtocolError("message has no integer schema version 'v'")
    if v > SCHEMA_VERSION:
        raise ProtocolError(
            f"message uses schema version {v}, newer than this client's {SCHEMA_VERSION}; "
            "upgrade stiction to read it"
        )
    if v < 1:
        raise ProtocolError(f"invalid schema version {v}")


def _vec(value: Any, where: str) -> list[float]:
    if (
        not isinstance(value, list)
        or len(value) != 2
        or not all(
            isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c)
            for c in value
        )
    ):
        raise ProtocolError(f"{where} must be a list of two finite numbers")
    return [float(value[0]), float(value[1])]


def _num(value: Any, where: str) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise ProtocolError(f"{where} must be a finite number")
    return float(value)


def validate_frame(message: Mapping[str, Any]) -> FrameWire:
    """Check a decoded map against the frame shape; extra keys are kept."""
    check_version(message)
    if message.get("kind") != "frame":
        raise ProtocolError(f"expected kind 'frame', got {message.get('kind')!r}")
    tick = message.get("tick")
    if not isinstance(tick, int) or isinstance(tick, bool):
        raise ProtocolError("frame 'tick' must be an integer")
    if "prev_tick" in message:
        prev = message["prev_tick"]
        if not isinstance(prev, int) or isinstance(prev, bool) or not -1 <= prev < tick:
            raise ProtocolError("frame 'prev_tick' must be an integer from -1 to tick - 1")
    _num(message.get("t"), "frame 't'")
    if message.get("t_input") is not None:
        _num(message.get("t_input"), "frame 't_input'")
    if not isinstance(message.get("device"), str):
        raise ProtocolError("frame 'device' must be a string")
    contacts = message.get("contacts")
    if not isinstance(contacts, list):
        raise ProtocolError("frame 'contacts' must be a list")
    for i, c in enumerate(contacts):
        where = f"contacts[{i}]"
        if not isinstance(c, dict):
            raise ProtocolError(f"{where} must be a map")
        if not isinstance(c.get("id"), int):
            raise ProtocolError(f"{where}.id must be an integer")
        if c.get("phase") not in PHASES:
            raise ProtocolError(f"{where}.phase must be one of {', '.join(PHASES)}")
        for key in ("touch_m", "pointer_m", "touch_px", "pointer_px"):
            _vec(c.get(key), f"{where}.{key}")
        _num(c.get("tension"), f"{where}.tension")
        if not isinstance(c.get("material"), str):
            raise ProtocolError(f"{where}.material must be a string")
        if "string" in c:
            s = c["string"]
            if not isinstance(s, dict):
                raise ProtocolError(f"{where}.string must be a map")
            _num(s.get("length_px"), f"{where}.string.length_px")
            _vec(s.get("dir"), f"{where}.string.dir")
    return cast(FrameWire, message)


def decode_frame(payload: bytes) -> FrameWire:
    """Decode and validate one frame payload (the last part of a published message)."""
    return validate_frame(decode(payload))


# --- control endpoint (REQ/REP) -------------------------------------------------

ControlOp = Literal[
    "ping", "get_scene", "set_scene", "get_params", "set_params", "devices", "stats", "snapshot"
]
CONTROL_OPS: tuple[ControlOp, ...] = (
    "ping",
    "get_scene",
    "set_scene",
    "get_params",
    "set_params",
    "devices",
    "stats",
    "snapshot",
)


def make_request(op: ControlOp, **args: Any) -> bytes:
    """A control request: ``{"v": 1, "op": op, ...args}``."""
    return encode({"v": SCHEMA_VERSION, "op": op, **args})


def parse_request(payload: bytes) -> tuple[ControlOp, dict[str, Any]]:
    """Split a request into its op and arguments; raise ProtocolError for anything else."""
    msg = decode(payload)
    check_version(msg)
    op = msg.pop("op", None)
    msg.pop("v", None)
    if op not in CONTROL_OPS:
        # reprlib keeps an op of any size to a few dozen characters in the reply and the log
        raise ProtocolError(f"unknown op {_brief.repr(op)}; known: {', '.join(CONTROL_OPS)}")
    return cast(ControlOp, op), msg


def ok_reply(**data: Any) -> bytes:
    """An untyped ``ok`` reply, for tools that answer in the daemon's place
    (clients/replay.py); the daemon's own replies use the typed builders below."""
    return encode({"v": SCHEMA_VERSION, "ok": True, **data})


class ErrorReply(TypedDict):
    v: int
    ok: Literal[False]
    error: str


def error_message(message: str) -> ErrorReply:
    return {"v": SCHEMA_VERSION, "ok": False, "error": message}


def error_reply(message: str) -> bytes:
    return encode(error_message(message))


def parse_reply(payload: bytes) -> dict[str, Any]:
    """Decode a reply; a reply with ``ok: false`` raises ProtocolError with its error text."""
    msg = decode(payload)
    check_version(msg)
    if msg.get("ok") is not True:
        raise ProtocolError(str(msg.get("error", "request failed without an error message")))
    return msg


# --- scene messages (topic "scene") and snapshots ------------------------------
# Added for the daemon; see docs/protocol.md "Scene" and "Late subscribers".

KIND_FRAME = "frame"
KIND_SCENE = "scene"
PASS_THROUGH = "pass-through"
"""Material name reported for a contact over an area with no material."""
EFFECTS: tuple[str, ...] = ("stick_slip", "string", "pressure_load")
SHAPES: tuple[str, ...] = ("rect", "circle", "polygon")


class MaterialWire(TypedDict):
    mu_s: float
    mu_k: float
    k: float
    m: float
    g: float
    C_l: float
    color: NotRequired[str]


class RegionWire(TypedDict):
    name: str
    material: str
    shape: Literal["rect", "circle", "polygon"]
    rect: NotRequired[list[float]]
    center: NotRequired[list[float]]
    radius: NotRequired[float]
    points: NotRequired[list[list[float]]]


class SceneWire(TypedDict):
    name: str
    source: str
    display: list[int]
    effects: list[str]
    outside: str
    materials: dict[str, MaterialWire]
    regions: list[RegionWire]


class SceneMessageWire(TypedDict):
    v: int
    kind: Literal["scene"]
    tick: int
    scene: SceneWire


def scene_message(scene: SceneWire, tick: int) -> SceneMessageWire:
    """The payload published on TOPIC_SCENE; `tick` is the last tick sent before it."""
    return {"v": SCHEMA_VERSION, "kind": "scene", "tick": tick, "scene": scene}


def validate_scene_message(message: Mapping[str, Any]) -> SceneMessageWire:
    """Check a decoded scene message's outline (the scene's keys and region shapes)."""
    check_version(message)
    if message.get("kind") != KIND_SCENE:
        raise ProtocolError(f"expected kind 'scene', got {message.get('kind')!r}")
    tick = message.get("tick")
    if not isinstance(tick, int) or isinstance(tick, bool):
        raise ProtocolError("scene message 'tick' must be an integer")
    scene = message.get("scene")
    if not isinstance(scene, dict):
        raise ProtocolError("scene message 'scene' must be a map")
    display = scene.get("display")
    _vec(display, "scene.display")
    if not isinstance(scene.get("materials"), dict):
        raise ProtocolError("scene.materials must be a map")
    regions = scene.get("regions")
    if not isinstance(regions, list):
        raise ProtocolError("scene.regions must be a list")
    for i, r in enumerate(regions):
        if not isinstance(r, dict) or r.get("shape") not in SHAPES:
            raise ProtocolError(f"scene.regions[{i}].shape must be one of {', '.join(SHAPES)}")
    return cast(SceneMessageWire, message)


def decode_message(payload: bytes) -> FrameWire | SceneMessageWire:
    """Decode any published payload, dispatching on its ``kind``."""
    msg = decode(payload)
    if msg.get("kind") == KIND_SCENE:
        return validate_scene_message(msg)
    return validate_frame(msg)


def is_local_endpoint(endpoint: str) -> bool:
    """True for ipc://, inproc:// and tcp:// on a loopback address."""
    scheme, _, rest = endpoint.partition("://")
    if scheme in ("ipc", "inproc"):
        return True
    if scheme != "tcp":
        return False
    host = rest.rsplit(":", 1)[0] if ":" in rest else rest
    host = host.strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # an interface name or "*": the network


# --- control replies, one typed builder each (docs/protocol.md "Control") --------
# Every reply is ``{"v", "ok": true, ...}``; the keys follow in the order given
# here, which is the order on the wire.


class PingReply(TypedDict):
    v: int
    ok: Literal[True]
    tick: int
    version: str
    rate: float
    keepalive: float


def ping_reply(tick: int, version: str, rate: float, keepalive: float) -> PingReply:
    return {
        "v": SCHEMA_VERSION,
        "ok": True,
        "tick": tick,
        "version": version,
        "rate": rate,
        "keepalive": keepalive,
    }


class SceneReply(TypedDict):
    """`get_scene` (with the TOML text) and `set_scene` (without)."""

    v: int
    ok: Literal[True]
    scene: SceneWire
    toml: NotRequired[str]


def scene_reply(scene: SceneWire, toml: str | None = None) -> SceneReply:
    reply: SceneReply = {"v": SCHEMA_VERSION, "ok": True, "scene": scene}
    if toml is not None:
        reply["toml"] = toml
    return reply


class ParamsReply(TypedDict):
    """`get_params` and `set_params`: the defaults, integrator and each material."""

    v: int
    ok: Literal[True]
    params: dict[str, float]
    integrator: str
    materials: dict[str, MaterialWire]


def params_reply(
    params: Mapping[str, float], integrator: str, materials: dict[str, MaterialWire]
) -> ParamsReply:
    return {
        "v": SCHEMA_VERSION,
        "ok": True,
        "params": dict(params),
        "integrator": integrator,
        "materials": materials,
    }


DeviceState = Literal["open", "absent", "waiting", "ended"]


class DeviceWire(TypedDict):
    name: str
    spec: str
    kind: str
    state: DeviceState
    surface_m: list[float] | None
    mapping: str


class DevicesReply(TypedDict):
    v: int
    ok: Literal[True]
    devices: list[DeviceWire]


def devices_reply(devices: list[DeviceWire]) -> DevicesReply:
    return {"v": SCHEMA_VERSION, "ok": True, "devices": devices}


class Summary(TypedDict):
    """p50, p99 and max of a window in milliseconds; None before the first value."""

    p50: float | None
    p99: float | None
    max: float | None


class DeviceStatsWire(TypedDict):
    state: DeviceState
    spec: str
    samples: int
    rejected: int
    errors: int
    reopened: int
    clock_steps: int
    driver: dict[str, int]
    rate_hz: NotRequired[float]
    """Absent until measured (a statistic not measured yet is absent, not 0.0)."""


class StatsWire(TypedDict):
    uptime_s: float
    rate: float
    clock: str
    ticks: int
    late_ticks: int
    skipped_deadlines: int
    idle_deadlines: int
    idle_wakes: int
    realtime: int
    late_threshold_ms: float
    jitter_ms: Summary
    latency_ms: Summary
    tick_cost_ms: Summary
    tick_cpu_ms: Summary
    prepared_hits: int
    """Device ticks sent as prepared before the deadline (stiction.daemon.prepare)."""
    prepared_misses: int
    """Device ticks prepared, then dropped for an ordinary tick (input arrived in between)."""
    unprepared: int
    """Device ticks with nothing prepared (no spin before them, a relative mapping, ...)."""
    published: int
    publish_dropped: int
    control_requests: int
    control_errors: int
    scene_loads: int
    scene_errors: int
    reloads: int
    devices: dict[str, DeviceStatsWire]


class StatsReply(TypedDict):
    v: int
    ok: Literal[True]
    stats: StatsWire


def stats_reply(stats: StatsWire) -> StatsReply:
    return {"v": SCHEMA_VERSION, "ok": True, "stats": stats}


class SnapshotReply(TypedDict):
    """What a late subscriber draws first: the scene and every device's last frame."""

    v: int
    ok: Literal[True]
    tick: int
    scene: SceneWire
    frames: dict[str, FrameWire]
    keepalive: float


def snapshot_reply(
    tick: int, scene: SceneWire, frames: Mapping[str, FrameWire], keepalive: float
) -> SnapshotReply:
    return {
        "v": SCHEMA_VERSION,
        "ok": True,
        "tick": tick,
        "scene": scene,
        "frames": dict(frames),
        "keepalive": keepalive,
    }


Reply = (
    PingReply | SceneReply | ParamsReply | DevicesReply | StatsReply | SnapshotReply | ErrorReply
)
"""Any reply the control endpoint sends."""
