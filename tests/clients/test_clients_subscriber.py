"""Subscriber and AsyncSubscriber against a stand-in daemon on real ZeroMQ sockets."""

from __future__ import annotations

import asyncio
import math
import shutil
import socket
import threading
from pathlib import Path

import msgpack
import numpy as np
import pytest
import zmq
from clients_support import SCENE, FakeDaemon, make_contact, make_frame, scene_message, stroke

from stiction import protocol
from stiction.clients import (
    AsyncSubscriber,
    ControlUnavailable,
    Frame,
    SceneMessage,
    Subscriber,
)
from stiction.clients.curve import CurveKeys
from stiction.errors import ProtocolError, StictionError

pytest_plugins = ["clients_fixtures"]


def _keypair(directory, name):  # type: ignore[no-untyped-def]
    """The project's own writer: the secret half is private (0600), as the daemon requires."""
    from stiction.keyfiles import write_keypair

    public, secret = write_keypair(Path(directory), name, force=True)
    return str(public), str(secret)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_frames_arrive_as_typed_objects(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint) as sub:
        daemon.wait_subscribers()
        wire = make_frame(7, "pen", [make_contact((10, 20), (13, 24), "stick")], extra_key=1)
        daemon.send(wire)
        frame = sub.recv(timeout=10)
    assert isinstance(frame, Frame)
    assert (frame.tick, frame.device, frame.v) == (7, "pen", 1)
    assert frame.t == pytest.approx(100.07)
    (c,) = frame.contacts
    assert c.phase == "stick" and c.pointer_px == (10.0, 20.0) and c.touch_px == (13.0, 24.0)
    assert c.string is not None and c.string.dir == pytest.approx((0.6, 0.8))
    end = c.string_end_px
    assert end is not None
    assert end[0] == pytest.approx(10 + 0.6 * 2000 * math.sqrt(0.001))
    # Keys the client does not know are kept, so nothing a newer daemon adds is lost.
    assert frame.wire["extra_key"] == 1
    assert '"extra_key":1' in frame.to_json()


def test_device_filter_is_exact_not_a_prefix(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint, devices=["pen"]) as sub:
        daemon.wait_subscribers()
        for dev in ("pen2", "touchpad", "pen"):
            daemon.send(make_frame(1, dev))
        got = sub.recv(timeout=10)
        assert isinstance(got, Frame) and got.device == "pen"
        assert sub.recv(timeout=0.05) is None


def test_kind_filter_scene_and_frames(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint, kinds=["scene"]) as only_scene:
        daemon.wait_subscribers()
        daemon.send(make_frame(1))
        daemon.send(scene_message(3))
        msg = only_scene.recv(timeout=10)
        assert isinstance(msg, SceneMessage) and msg.tick == 3
        assert msg.scene["display"] == [400, 300]
        assert only_scene.stats.frames == 0


def test_unknown_kind_is_a_user_error() -> None:
    with pytest.raises(StictionError, match="unknown message kind"):
        Subscriber("ipc:///tmp/nothing-here", kinds=["frames"])


def test_bad_messages_are_skipped_and_counted(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint) as sub:
        daemon.wait_subscribers()
        bad_contact = make_contact((1, 1), (2, 2))
        bad_contact["pointer_px"] = [float("nan"), 1.0]
        daemon.send_raw(b"frame.pen", b"\xc1garbage")
        daemon.send_raw(b"frame.pen")
        daemon.send_raw(b"frame.pen", msgpack.packb([1, 2, 3]))
        daemon.send(make_frame(1, contacts=[bad_contact]))
        daemon.send({**make_frame(2), "kind": "scene"}, topic=b"frame.pen")
        daemon.send(make_frame(3), topic=b"frame.other")
        daemon.send(make_frame(4))
        frame = sub.recv(timeout=10)
        assert isinstance(frame, Frame) and frame.tick == 4
        assert sub.stats.bad == 6
        assert sub.stats.received == 7
        assert sub.stats.last_error and "topic" in sub.stats.last_error


def test_newer_schema_is_rejected_with_a_clear_message(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint) as sub:
        daemon.wait_subscribers()
        daemon.send({**make_frame(1), "v": protocol.SCHEMA_VERSION + 1, "contacts": "new shape"})
        with pytest.raises(ProtocolError, match=r"newer than this client.*upgrade"):
            sub.recv(timeout=10)


def test_conflation_keeps_the_latest_frame_per_device() -> None:
    # inproc: a sent message is in the subscriber's pipe when send returns, so
    # "everything published before recv" is exact and the test deterministic.
    ctx = zmq.Context()
    d = FakeDaemon("inproc://conflate", context=ctx)
    try:
        with Subscriber("inproc://conflate", conflate=True, context=ctx) as sub:
            d.wait_subscribers()
            for tick in range(100):
                d.send(make_frame(tick, "a"))
                d.send(make_frame(tick, "b"))
            first = sub.recv(timeout=10)
            second = sub.recv(timeout=10)
            assert isinstance(first, Frame) and isinstance(second, Frame)
            assert {(first.device, first.tick), (second.device, second.tick)} == {
                ("a", 99),
                ("b", 99),
            }
            assert sub.recv(timeout=0) is None
            assert sub.stats.conflated == 198 and sub.stats.frames == 2
            d.send(make_frame(100, "a"))
            nxt = sub.recv(timeout=10)
            assert isinstance(nxt, Frame) and nxt.tick == 100
    finally:
        d.close()
        ctx.term()


def test_without_conflation_every_frame_arrives_in_order(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint) as sub:
        daemon.wait_subscribers()
        for wire in stroke(200):
            daemon.send(wire)
        ticks = [f.tick for f in sub.frames(count=200, seconds=30)]
    assert ticks == list(range(200))
    assert sub.stats.missed == 0


def test_gaps_are_counted(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint) as sub:
        daemon.wait_subscribers()
        for tick in (1, 2, 6):
            daemon.send(make_frame(tick))
        assert [f.tick for f in sub.frames(count=3, seconds=30)] == [1, 2, 6]
        assert sub.stats.missed == 3


def test_prev_tick_tells_a_device_that_was_away_from_lost_frames(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint) as sub:
        daemon.wait_subscribers()
        # 3 -> 9: the device was unplugged, its frame 9 names 3 as its last.
        # 10 -> 15: frame 15 names 12, so 11 and 12 were lost on the way.
        sent = [(2, 1), (3, 2), (9, 3), (10, 9), (15, 12)]
        for tick, prev in sent:
            daemon.send(make_frame(tick, prev_tick=prev))
        frames = list(sub.frames(count=5, seconds=30))
        assert [(f.tick, f.prev_tick) for f in frames] == sent
        assert sub.stats.missed == 2


@pytest.mark.parametrize("transport", ["ipc", "tcp"])
def test_daemon_restart_is_only_a_gap(transport: str, endpoints: tuple[str, str]) -> None:
    pub = endpoints[0] if transport == "ipc" else f"tcp://127.0.0.1:{free_port()}"
    first = FakeDaemon(pub)
    with Subscriber(pub) as sub:
        first.wait_subscribers()
        for tick in range(10):
            first.send(make_frame(tick))
        assert [f.tick for f in sub.frames(count=10, seconds=30)] == list(range(10))
        first.close()
        second = FakeDaemon(pub)
        # The caller keeps reading, as a real client does: libzmq attaches the
        # reconnected pipe (and re-sends the subscription) while the socket is
        # in use, so the reader runs in a thread while this one publishes.
        got: list[int] = []
        reader = threading.Thread(
            target=lambda: got.extend(f.tick for f in sub.frames(count=5, seconds=30))
        )
        reader.start()
        try:
            second.wait_subscribers()  # the subscriber found the new daemon by itself
            for tick in range(5):
                second.send(make_frame(tick))
            reader.join(30)
            assert got == list(range(5))
            st = sub.stats
            assert st.disconnects == 1 and st.reconnects == 1
            assert st.missed == 0 and st.bad == 0
        finally:
            reader.join(30)
            second.close()


def test_snapshot_then_stream_without_duplicates(daemon: FakeDaemon) -> None:
    snap_frame = make_frame(5, contacts=[make_contact((50, 60), (55, 60))])
    daemon.snapshot = {"tick": 5, "scene": SCENE, "frames": {"pen": snap_frame}}
    with Subscriber(
        daemon.pub_endpoint, kinds=["frame", "scene"], control=daemon.control_endpoint
    ) as sub:
        scene = sub.recv(timeout=10)
        first = sub.recv(timeout=10)
        assert isinstance(scene, SceneMessage) and scene.scene["name"] == "test scene"
        assert isinstance(first, Frame) and first.tick == 5
        assert first.contacts[0].pointer_px == (50.0, 60.0)
        daemon.wait_subscribers(2)
        daemon.send(scene_message(4))  # in force before the snapshot: stale
        for tick in range(3, 9):
            daemon.send(make_frame(tick))
        daemon.send(scene_message(8))
        assert [f.tick for f in sub.frames(count=3, seconds=30)] == [6, 7, 8]
        newer = sub.recv(timeout=10)
        assert isinstance(newer, SceneMessage) and newer.tick == 8
        assert sub.stats.stale == 4
    assert daemon.requests == ["snapshot"]


def test_unreachable_control_endpoint_is_a_clear_error(endpoints: tuple[str, str]) -> None:
    with pytest.raises(ControlUnavailable, match="no reply to 'snapshot'"):
        Subscriber(endpoints[0], control=endpoints[1], snapshot_timeout=0.2)


def test_bad_endpoint_is_a_user_error() -> None:
    with pytest.raises(StictionError, match="cannot connect"):
        Subscriber("nonsense://x")


def test_collect_gives_numpy_columns(daemon: FakeDaemon) -> None:
    with Subscriber(daemon.pub_endpoint) as sub:
        daemon.wait_subscribers()
        daemon.send(make_frame(0))  # a frame with no contact still has a frame row
        for wire in stroke(10):
            daemon.send({**wire, "tick": wire["tick"] + 1})
        table = sub.collect(count=11, seconds=30)
    assert table.frame_count == 11 and len(table) == 10
    assert table.contact_frame.tolist() == list(range(1, 11))
    assert table.tick.tolist() == list(range(1, 11))
    assert table.pointer_px.shape == (10, 2)
    assert np.all(table.pointer_px[:5] == [100.0, 150.0])
    assert table.phase[:5].tolist() == ["stick"] * 5
    assert np.isfinite(table.string_px).all()
    assert set(table.as_dict()) >= {"tick", "pointer_px", "string_px", "frame_t_input"}


def test_async_subscriber_reads_and_conflates(daemon: FakeDaemon) -> None:
    async def main() -> tuple[list[int], int]:
        sub = AsyncSubscriber(daemon.pub_endpoint)
        async with sub:
            await asyncio.get_running_loop().run_in_executor(None, daemon.wait_subscribers)
            for wire in stroke(20):
                daemon.send(wire)
            ticks = [f.tick async for f in sub.frames(count=20)]
            timed_out = await sub.recv(timeout=0.01)
            assert timed_out is None
            return ticks, sub.stats.frames

    ticks, n = asyncio.run(main())
    assert ticks == list(range(20)) and n == 20


def test_async_subscriber_snapshot(daemon: FakeDaemon) -> None:
    daemon.snapshot = {"tick": 2, "frames": [make_frame(2)]}

    async def main() -> list[int]:
        async with AsyncSubscriber(daemon.pub_endpoint, control=daemon.control_endpoint) as sub:
            await asyncio.get_running_loop().run_in_executor(None, daemon.wait_subscribers)
            for tick in range(5):
                daemon.send(make_frame(tick))
            return [f.tick async for f in sub.frames(count=3)]

    assert asyncio.run(main()) == [2, 3, 4]


def test_curve_daemon_talks_only_to_authorised_clients(short_dir: Path) -> None:
    import zmq.auth
    from zmq.auth.thread import ThreadAuthenticator

    keys, allowed = short_dir / "keys", short_dir / "authorized"
    keys.mkdir()
    allowed.mkdir()
    server_pub, server_secret = _keypair(keys, "daemon")
    client_pub, client_secret = _keypair(keys, "client")
    _, stranger_secret = _keypair(keys, "stranger")
    shutil.copy(client_pub, allowed)
    ctx = zmq.Context()
    auth = ThreadAuthenticator(ctx)
    auth.start()
    auth.configure_curve(domain="stiction", location=str(allowed))
    pub = f"tcp://127.0.0.1:{free_port()}"
    d = FakeDaemon(pub, context=ctx, curve_secret=Path(server_secret))
    try:
        good = Subscriber(pub, curve=CurveKeys.from_files(server_pub, client_secret))
        stranger = Subscriber(pub, curve=CurveKeys.from_files(server_pub, stranger_secret))
        plain = Subscriber(pub)
        d.wait_subscribers()  # only the authorised client gets this far
        d.send(make_frame(1))
        msg = good.recv(timeout=10)
        assert isinstance(msg, Frame) and msg.tick == 1
        # Refused peers never receive a frame (the daemon does not read them at all).
        assert stranger.recv(timeout=0.2) is None and plain.recv(timeout=0.2) is None
        for s in (good, stranger, plain):
            s.close()
    finally:
        d.close()
        auth.stop()
        ctx.term()


def test_curve_key_files_are_checked(short_dir: Path) -> None:

    public, _secret = _keypair(short_dir, "x")
    with pytest.raises(StictionError, match="cannot read CURVE key"):
        CurveKeys.from_files(short_dir / "missing.key", public)
    with pytest.raises(StictionError, match="no secret key"):
        CurveKeys.from_files(public, public)
