"""The wire schema: round trips, validation, and the version rule."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import msgpack
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stiction import protocol
from stiction.errors import ProtocolError


def _frame(**over: object) -> dict[str, object]:
    frame: dict[str, object] = {
        "v": 1,
        "kind": "frame",
        "tick": 7,
        "t": 12.5,
        "t_input": 12.497,
        "device": "synthetic:pen",
        "contacts": [
            {
                "id": 0,
                "phase": "stick",
                "touch_m": [0.01, 0.02],
                "pointer_m": [0.009, 0.02],
                "touch_px": [100.0, 200.0],
                "pointer_px": [90.0, 200.0],
                "tension": 1e-4,
                "material": "rubber",
                "string": {"length_px": 20.0, "dir": [1.0, 0.0]},
            }
        ],
    }
    frame.update(over)
    return frame


def test_frame_round_trip_keeps_every_key() -> None:
    frame = _frame(extra="kept")
    assert protocol.decode_frame(protocol.encode(frame)) == frame


def test_newer_schema_is_refused_with_a_clear_message() -> None:
    with pytest.raises(ProtocolError, match="newer than this client"):
        protocol.decode_frame(protocol.encode(_frame(v=protocol.SCHEMA_VERSION + 1)))


@pytest.mark.parametrize(
    "payload",
    [
        b"",
        b"\xc1",
        msgpack.packb([1, 2, 3]),
        msgpack.packb({"v": 1, "kind": "frame"}),
        protocol.encode(_frame(tick="7")),
        protocol.encode(_frame(t=math.nan)),
        protocol.encode(_frame(contacts=[{"id": 0, "phase": "flying"}])),
        protocol.encode(
            _frame(contacts=[{**_frame()["contacts"][0], "pointer_px": [math.nan, 1.0]}])  # type: ignore[index]
        ),
    ],
)
def test_malformed_frames_raise_protocol_error(payload: bytes) -> None:
    with pytest.raises(ProtocolError):
        protocol.decode_frame(payload)


def test_control_request_round_trip_and_unknown_op() -> None:
    op, args = protocol.parse_request(protocol.make_request("set_params", mu_s=0.5))
    assert (op, args) == ("set_params", {"mu_s": 0.5})
    with pytest.raises(ProtocolError, match="unknown op"):
        protocol.parse_request(protocol.encode({"v": 1, "op": "format_disk"}))


def test_error_reply_raises_with_its_text() -> None:
    with pytest.raises(ProtocolError, match="no such device"):
        protocol.parse_reply(protocol.error_reply("no such device"))
    assert protocol.parse_reply(protocol.ok_reply(tick=3))["tick"] == 3


def test_topics_filter_by_prefix() -> None:
    assert protocol.frame_topic("hid:256c:006d").startswith(protocol.TOPIC_FRAME)


def test_frame_builder_writes_the_documented_frame_byte_for_byte() -> None:
    hand = _frame(prev_tick=6)
    order = ["v", "kind", "tick", "prev_tick", "t", "t_input", "device", "contacts"]
    hand = {k: hand[k] for k in order}
    c = hand["contacts"][0]  # type: ignore[index]
    built = protocol.frame(
        7,
        6,
        12.5,
        12.497,
        "synthetic:pen",
        [protocol.contact(**c)],  # type: ignore[arg-type]
    )
    assert protocol.encode(built) == protocol.encode(hand)
    no_string = {k: v for k, v in c.items() if k != "string"}
    assert "string" not in protocol.contact(**no_string)  # type: ignore[arg-type]


def test_every_reply_builder_starts_with_version_and_ok_and_parses() -> None:
    scene = {"name": "s", "source": "<x>", "display": [10, 10], "effects": [],
             "outside": "pass-through", "materials": {}, "regions": []}  # fmt: skip
    frame = protocol.validate_frame(_frame(prev_tick=6))
    replies = [
        protocol.ping_reply(3, "1.0", 100.0, 1.0),
        protocol.scene_reply(scene, "toml text"),  # type: ignore[arg-type]
        protocol.scene_reply(scene),  # type: ignore[arg-type]
        protocol.params_reply({"k": 1.0}, "default", {}),
        protocol.devices_reply([]),
        protocol.snapshot_reply(3, scene, {"pen": frame}, 1.0),  # type: ignore[arg-type]
    ]
    for reply in replies:
        assert list(reply)[:2] == ["v", "ok"]
        assert protocol.parse_reply(protocol.encode(reply)) == reply
    assert "toml" not in replies[2]
    with pytest.raises(ProtocolError, match=r"^boom$"):
        protocol.parse_reply(protocol.encode(protocol.error_message("boom")))
    assert protocol.error_reply("boom") == protocol.encode(protocol.error_message("boom"))


_leaf = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**64 - 1),
    st.floats(allow_nan=False),
    st.text(max_size=20),
    st.binary(max_size=20),
)
_values = st.recursive(
    _leaf,
    lambda kids: (
        st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4)
    ),
    max_leaves=30,
)


@given(st.dictionaries(st.text(max_size=8), _values, max_size=6))
def test_encode_is_msgpack_packb_byte_for_byte(message: dict[str, object]) -> None:
    # encode keeps one Packer per thread; what it returns must not depend on that
    assert protocol.encode(message) == msgpack.packb(message, use_bin_type=True)


def test_a_message_that_fails_to_encode_leaves_nothing_in_the_kept_packer() -> None:
    good = {"v": 1, "op": "ping"}
    for bad in ({"v": 1, "x": object()}, {"v": 1, "x": 2**70}, {"v": 1, "x": [1, {2, 3}]}):
        with pytest.raises(ProtocolError, match="cannot encode"):
            protocol.encode(bad)
        assert protocol.encode(good) == msgpack.packb(good, use_bin_type=True)


def test_encode_from_many_threads_at_once_gives_each_its_own_bytes() -> None:
    messages = [{"v": 1, "n": n, "pad": "x" * (n % 50)} for n in range(400)]
    with ThreadPoolExecutor(max_workers=8) as pool:
        got = list(pool.map(protocol.encode, messages))
    assert got == [msgpack.packb(m, use_bin_type=True) for m in messages]
