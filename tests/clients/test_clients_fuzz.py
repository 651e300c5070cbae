"""Whatever arrives on the socket, a subscriber either delivers a well-formed
message, skips and counts it, or (only for a newer schema) says so."""

from __future__ import annotations

import json
import math
from typing import Any

import msgpack
from clients_support import make_contact, make_frame, scene_message
from hypothesis import given
from hypothesis import strategies as st

from stiction import protocol
from stiction.clients.messages import Frame, SceneMessage, wire_to_json
from stiction.clients.stream import StreamState
from stiction.errors import ProtocolError

pytest_plugins = ["clients_fixtures"]

scalars = (
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**64 - 1)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8)
    | st.binary(max_size=8)
)
values = st.recursive(
    scalars,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4)
    ),
    max_leaves=12,
)
KEYS = ["v", "kind", "tick", "t", "t_input", "device", "contacts"]
CONTACT_KEYS = ["id", "phase", "touch_m", "pointer_m", "touch_px", "pointer_px", "tension"]
CONTACT_KEYS += ["material", "string"]


def strict_json(text: str) -> Any:
    def refuse(name: str) -> None:
        raise AssertionError(f"{name} in JSON")

    return json.loads(text, parse_constant=refuse)


def check(state: StreamState, parts: list[bytes]) -> None:
    try:
        msg = state.accept(parts)
    except ProtocolError as exc:
        assert "newer than this client" in str(exc)
        return
    if msg is None:
        return
    assert isinstance(msg, Frame | SceneMessage)
    strict_json(msg.to_json())
    if isinstance(msg, Frame):
        for c in msg.contacts:
            for vec in (c.touch_m, c.pointer_m, c.touch_px, c.pointer_px):
                assert all(math.isfinite(x) for x in vec)


def base_frame() -> dict[str, Any]:
    return make_frame(3, contacts=[make_contact((1.0, 2.0), (3.0, 4.0))])


@given(st.lists(st.binary(max_size=64), max_size=3))
def test_random_bytes(parts: list[bytes]) -> None:
    check(StreamState(("frame", "scene"), None, False), parts)


@given(st.sampled_from(KEYS), values)
def test_a_frame_key_replaced_by_anything(key: str, value: Any) -> None:
    frame = base_frame()
    frame[key] = value
    payload = msgpack.packb(frame, use_bin_type=True)
    check(StreamState(("frame",), None, False), [b"frame.pen", payload])


@given(st.sampled_from(CONTACT_KEYS), values, values)
def test_a_contact_key_replaced_by_anything(key: str, value: Any, extra: Any) -> None:
    frame = base_frame()
    frame["contacts"][0][key] = value
    frame["unknown_extra"] = extra  # may be NaN: JSON output must still be valid
    payload = msgpack.packb(frame, use_bin_type=True)
    check(StreamState(("frame",), None, True), [b"frame.pen", payload])


@given(values)
def test_scene_messages_with_anything_inside(value: Any) -> None:
    msg = scene_message(2)
    msg["scene"] = {**msg["scene"], "regions": value} if isinstance(value, list) else value
    payload = msgpack.packb(msg, use_bin_type=True)
    check(StreamState(("scene",), None, False), [protocol.TOPIC_SCENE, payload])


def test_nan_in_an_unknown_key_becomes_null_not_invalid_json() -> None:
    assert strict_json(wire_to_json({"a": float("nan"), "b": [float("inf"), 1.5]})) == {
        "a": None,
        "b": [None, 1.5],
    }
