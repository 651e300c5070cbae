"""The loop publishes through the object it is given: a Recorder sees every
payload, and what the compiled pipeline writes has the protocol builders' shape."""

from __future__ import annotations

import inspect

import msgpack
from daemon_support import ListSource, make_daemon, stroke

from stiction import protocol
from stiction.daemon.publisher import Recorder


def test_a_given_publisher_gets_the_scene_then_a_frame_per_tick(
    endpoints: tuple[str, str],
) -> None:
    recorder = Recorder()
    d = make_daemon(endpoints, {"replay:pen": ListSource(stroke(n=100))}, recorder,
                    clock="virtual")  # fmt: skip
    try:
        assert d.publisher is recorder
        assert d.run() == 0
        ticks = d.schedule.ticks
    finally:
        d.close()
    topics = [t for t, _ in recorder.messages]
    assert topics[0] == protocol.TOPIC_SCENE
    assert topics[1:] == [protocol.frame_topic("test-pen")] * ticks
    assert recorder.sent == ticks + 1 and ticks > 30
    frames = [msgpack.unpackb(p) for _, p in recorder.messages[1:]]
    frame_keys = list(inspect.signature(protocol.frame).parameters)
    contact_keys = list(inspect.signature(protocol.contact).parameters)
    seen = 0
    for f in frames:
        assert list(f) == ["v", "kind", *frame_keys]
        for c in f["contacts"]:
            # key for key, in order, what protocol.contact() would have written
            assert list(c) == contact_keys[: len(c)]
            seen += 1
    assert seen > 30
    assert any("string" in c for f in frames for c in f["contacts"])
