"""The daemon loop end to end, with real ZeroMQ sockets and real drivers' replays."""

from __future__ import annotations

import itertools
import math
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zmq
from daemon_support import ListSource, Runner, drain, make_daemon, request, stroke, subscribe
from hypothesis import given, settings
from hypothesis import strategies as st

from stiction import protocol
from stiction.daemon.devices import DeviceConfig
from stiction.daemon.hotplug import Hotplug
from stiction.daemon.options import Options
from stiction.daemon.publisher import Recorder
from stiction.daemon.service import Daemon
from stiction.drivers.sample import PenSample
from stiction.sim import ContactSim, Params


def _run_virtual(endpoints: tuple[str, str], spec: str) -> list[tuple[bytes, bytes]]:
    o = Options(pub=endpoints[0], control=endpoints[1], clock="virtual", hotplug=False)
    o.devices = [DeviceConfig(spec)]
    recorder = Recorder()
    d = Daemon(o, publisher=recorder)
    d.open()
    try:
        assert d.run() == 0  # returns by itself at the end of the stream
    finally:
        d.close()
    return recorder.messages


def test_virtual_clock_replay_is_byte_identical_and_ends_by_itself(
    evdev_data: Path, tmp_path: Path
) -> None:
    spec = f"replay:{evdev_data / 'uc-logic-wp5540u-pen.evemu'}"
    a = _run_virtual((f"ipc://{tmp_path}/a", f"ipc://{tmp_path}/b"), spec)
    b = _run_virtual((f"ipc://{tmp_path}/a", f"ipc://{tmp_path}/b"), spec)
    assert a == b
    frames = [msgpack.unpackb(p) for t, p in a if t.startswith(protocol.TOPIC_FRAME)]
    assert len(frames) > 500
    # A frame every tick, ticks consecutive and 10 ms apart (a virtual clock
    # never idles), each frame naming the one before.
    assert [f["tick"] for f in frames] == list(range(len(frames)))
    assert [f["prev_tick"] for f in frames] == list(range(-1, len(frames) - 1))
    dt = [b["t"] - a["t"] for a, b in itertools.pairwise(frames)]
    assert max(dt) == pytest.approx(0.01) and min(dt) == pytest.approx(0.01)
    phases = {c["phase"] for f in frames for c in f["contacts"]}
    assert {"stick", "slip", "hover"} <= phases
    for f in frames:
        protocol.validate_frame(f)


def _replay_samples(path: Path) -> list[PenSample]:
    from stiction.drivers.evdev.playback import open_replay

    src = open_replay(path, realtime=False)
    try:
        return list(src.samples())
    finally:
        src.close()


def test_daemon_gives_the_same_pointer_as_the_simulator_on_the_same_samples(
    evdev_data: Path, endpoints: tuple[str, str]
) -> None:
    """`stiction simulate` had not landed when this was written: the reference
    is ContactSim fed the same samples on the same tick grid."""
    path = evdev_data / "uc-logic-wp5540u-pen.evemu"
    sent = _run_virtual(endpoints, f"replay:{path}")
    frames = [msgpack.unpackb(p) for t, p in sent if t.startswith(protocol.TOPIC_FRAME)]
    samples = _replay_samples(path)
    t0 = samples[0].t
    sim = ContactSim(Params(), string=True)
    i = 0
    compared = 0
    for f in frames:
        t = t0 + f["tick"] / 100.0
        assert f["t"] == t
        batch = []
        while i < len(samples) and samples[i].t <= t:
            batch.append(samples[i])
            i += 1
        st = sim.advance(t, batch)
        if st.phase == "up" and not f["contacts"]:
            continue
        (c,) = f["contacts"]
        assert c["phase"] == st.phase
        assert c["pointer_m"] == pytest.approx([st.pointer_x, st.pointer_y], abs=1e-12)
        assert c["tension"] == pytest.approx(st.tension, abs=1e-15)
        assert c["string"]["length_px"] == pytest.approx(st.string_px, abs=1e-9)
        compared += st.phase in ("stick", "slip")
    assert compared > 300


def test_malformed_samples_are_counted_and_the_loop_keeps_going(
    endpoints: tuple[str, str],
) -> None:
    samples = stroke(n=100)
    samples[50] = PenSample(t=samples[50].t, x=math.nan, y=0.05, tip=True)
    samples[60] = PenSample(t=math.inf, x=0.1, y=0.05, tip=True)
    recorder = Recorder()
    d = make_daemon(endpoints, {"replay:nan": ListSource(samples)}, recorder, clock="virtual")
    sent = recorder.messages
    try:
        d.run()
        stats = d.stats()
    finally:
        d.close()
    assert stats["devices"]["test-pen"]["rejected"] == 2
    frames = [msgpack.unpackb(p) for t, p in sent if t.startswith(protocol.TOPIC_FRAME)]
    assert frames[-1]["contacts"][-1]["phase"] == "up"
    for f in frames:
        for c in f["contacts"]:
            assert all(math.isfinite(v) for v in c["pointer_m"] + c["touch_m"])


def test_a_subscriber_that_never_reads_does_not_stall_the_loop(
    endpoints: tuple[str, str],
) -> None:
    d = make_daemon(
        endpoints, {"replay:long": ListSource(stroke(n=20_000, dt=0.001))}, clock="virtual", hwm=5
    )
    ctx = zmq.Context.instance()
    dead = subscribe(ctx, d, endpoints[0])
    dead.rcvhwm = 1
    assert d.publisher is not None
    before = d.publisher.sent
    try:
        d.run()
        assert d.schedule.ticks > 2000
        assert d.publisher.sent - before == d.schedule.ticks + 1  # every frame + the scene
    finally:
        dead.close()
        d.close()


def test_control_ops_and_bad_requests(endpoints: tuple[str, str]) -> None:
    gate = threading.Event()
    d = make_daemon(endpoints, {"pen": ListSource(stroke(n=50), gate=gate)})
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    ctl = endpoints[1]
    with Runner(d):
        assert request(ctx, ctl, protocol.make_request("ping"))["ok"]
        bad = [
            b"not msgpack \xc1",
            msgpack.packb([1, 2]),
            msgpack.packb({"v": 1, "op": "format_disk"}),
            msgpack.packb({"v": 99, "op": "ping"}),
            protocol.make_request("set_scene", toml="[scene]\ndisplay = [1, -1]\n"),
            protocol.make_request("set_scene", path="/no/such/scene.toml"),
            protocol.make_request("set_scene"),
            protocol.make_request("set_params", mu_s=-1.0),
            protocol.make_request("set_params", rate=50.0),
            protocol.make_request("set_params", material="nope", mu_s=0.3),
            protocol.make_request("get_params", extra=1),
        ]
        for payload in bad:
            reply = request(ctx, ctl, payload)
            assert reply["ok"] is False and reply["error"], payload
        reply = request(ctx, ctl, protocol.make_request("set_scene", toml="[scene]\nx = 1\n"))
        assert reply["error"].startswith("<control>:2: scene.x: unknown key")
        assert request(ctx, ctl, protocol.make_request("get_scene"))["scene"]["name"] == "default"

        text = '[scene]\nname = "ice"\noutside = "ice"\n[materials.ice]\nmu_s = 0.1\nmu_k = 0.05\n'
        reply = request(ctx, ctl, protocol.make_request("set_scene", toml=text))
        assert reply["ok"] and reply["scene"]["name"] == "ice"
        got = request(ctx, ctl, protocol.make_request("get_scene"))
        assert got["toml"] == text
        reply = request(ctx, ctl, protocol.make_request("set_params", material="ice", mu_s=0.2))
        assert reply["materials"]["ice"]["mu_s"] == 0.2
        reply = request(ctx, ctl, protocol.make_request("set_params", k=0.2, g=9.81))
        assert reply["params"]["g"] == 9.81 and reply["materials"]["ice"]["k"] == 0.2
        devices = request(ctx, ctl, protocol.make_request("devices"))["devices"]
        assert devices[0]["name"] == "test-pen" and devices[0]["state"] == "open"
        stats = request(ctx, ctl, protocol.make_request("stats"))["stats"]
        assert stats["control_errors"] == len(bad) + 1
        assert stats["scene_errors"] == 3
        gate.set()
    messages = drain(sub, 50)
    scenes = [m for t, m in messages if t == protocol.TOPIC_SCENE]
    assert [s["scene"]["name"] for s in scenes] == ["default", "ice", "ice", "ice"]
    sub.close()


def test_snapshot_then_stream_has_no_gap(endpoints: tuple[str, str]) -> None:
    gate = threading.Event()
    # The stroke ends early: most frames after the snapshot are keep-alives.
    d = make_daemon(endpoints, {"pen": ListSource(stroke(n=50), gate=gate)}, keepalive=0.05)
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    ticks: list[int] = []
    seen = threading.Event()
    d.on_tick = lambda n: (ticks.append(n), seen.set() if n >= 5 else None)  # type: ignore[func-returns-value]
    with Runner(d):
        assert seen.wait(10)
        snap = request(ctx, endpoints[1], protocol.make_request("snapshot"))
        assert snap["ok"] and snap["tick"] >= 5
        assert snap["scene"]["name"] == "default"
        assert snap["frames"]["test-pen"]["tick"] == snap["tick"]
        after: list[dict[str, Any]] = []
        while len(after) < 5:
            assert sub.poll(5000)
            _, payload = sub.recv_multipart()
            m = msgpack.unpackb(payload)
            if m["kind"] == "frame" and m["tick"] > snap["tick"]:
                after.append(m)
        # The stream continues where the snapshot ended: nothing lost, nothing
        # twice (keep-alive ticks while the stroke is over, still consecutive).
        assert [m["tick"] for m in after] == list(range(snap["tick"] + 1, snap["tick"] + 6))
        assert [m["prev_tick"] for m in after] == list(range(snap["tick"], snap["tick"] + 5))
        gate.set()
    sub.close()


def test_unplugged_device_ends_its_contacts_and_is_reopened(endpoints: tuple[str, str]) -> None:
    # The first device stays touching, then vanishes (DeviceError) mid-stroke.
    pressing = [PenSample(t=i * 0.005, x=0.05 + i * 1e-4, y=0.05, tip=True) for i in range(20)]
    gate = threading.Event()
    first = ListSource(pressing, fail_at_end=True, gate=gate)
    second = ListSource(stroke(n=10), gate=threading.Event())
    d = make_daemon(endpoints, {"pen": first})
    d.hotplug = Hotplug(lambda: d.slots, lambda s: second, use_udev=False, on_ready=d.waker.wake)
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    thread_alive = False
    try:
        with Runner(d) as runner:
            held = _wait_for(
                sub, lambda m: any(c["phase"] == "stick" for c in m.get("contacts", []))
            )
            gate.set()
            gone = _wait_for(sub, lambda m: any(c["phase"] == "up" for c in m.get("contacts", [])))
            assert [c["phase"] for c in gone["contacts"]] == ["up"]
            assert gone["contacts"][0]["pointer_m"] == gone["contacts"][0]["touch_m"]
            # The closing "up" is like any other: the contact's last material
            # (the default scene has no pass-through area) and, with the string
            # effect, a string of length 0.
            before = held["contacts"][0]
            assert before["material"] != protocol.PASS_THROUGH
            assert gone["contacts"][0]["material"] == before["material"]
            assert ("string" in gone["contacts"][0]) == ("string" in before)
            if "string" in before:
                assert gone["contacts"][0]["string"]["length_px"] == 0.0
            # The loop answers control requests between ticks (or idle, as it
            # is now, with no device left): once it has answered, the tick that
            # ended the device is over.
            devs = request(ctx, endpoints[1], protocol.make_request("devices"))["devices"]
            assert devs[0]["state"] == "absent"
            assert d.slots[0].state == "absent" and d.slots[0].run is None
            assert d.slots[0].thread is not None
            d.slots[0].thread.join(10)
            assert d.hotplug.scan_once() == 1
            back = _wait_for(sub, lambda m: m.get("tick", -1) > gone["tick"])
            assert back["device"] == "test-pen"
            devs = request(ctx, endpoints[1], protocol.make_request("devices"))["devices"]
            assert devs[0]["state"] == "open"
            thread_alive = runner.thread.is_alive()
            second.gate.set()  # type: ignore[union-attr]
    finally:
        sub.close()
    assert thread_alive and first.closed.is_set()
    assert d.slots[0].reopened == 1


def _wait_for(sub: zmq.Socket[Any], pred: Any, limit: int = 2000) -> dict[str, Any]:
    for _ in range(limit):
        assert sub.poll(5000), "no message within 5 s"
        _, payload = sub.recv_multipart()
        m = msgpack.unpackb(payload)
        if m.get("kind") == "frame" and pred(m):
            return dict(m)
    raise AssertionError("condition not met")


def test_daemon_and_stiction_simulate_agree_on_a_recording(
    evdev_data: Path, endpoints: tuple[str, str], tmp_path: Path
) -> None:
    """The same recording both ways: the live daemon (virtual clock) and
    `stiction simulate` on its samples written as a trace."""
    from stiction import cli

    path = evdev_data / "uc-logic-wp5540u-pen.evemu"
    samples = _replay_samples(path)
    trace = tmp_path / "trace.csv"
    with trace.open("w") as f:
        f.write("t,x,y,contact\n")
        for s in samples:
            f.write(f"{s.t!r},{s.x!r},{s.y!r},{int(s.tip)}\n")
    out = tmp_path / "out.csv"
    assert cli.main(["simulate", str(trace), "--out", str(out)]) == 0
    rows = {}
    header, *lines = out.read_text().splitlines()
    names = header.split(",")
    for line in lines:
        row = dict(zip(names, line.split(","), strict=True))
        rows[round(float(row["t"]), 6)] = row

    sent = _run_virtual(endpoints, f"replay:{path}")
    frames = [msgpack.unpackb(p) for t, p in sent if t.startswith(protocol.TOPIC_FRAME)]
    compared = 0
    for f in frames:
        row = rows.get(round(f["t"], 6))
        if row is None or row["phase"] not in ("stick", "slip") or not f["contacts"]:
            continue
        (c,) = f["contacts"]
        assert c["phase"] == row["phase"], f["tick"]
        assert c["pointer_m"][0] == pytest.approx(float(row["pointer_x"]), abs=1e-12)
        assert c["pointer_m"][1] == pytest.approx(float(row["pointer_y"]), abs=1e-12)
        compared += 1
    assert compared > 300


def test_a_tablet_plugged_in_later_is_picked_up(endpoints: tuple[str, str]) -> None:
    """With no device named, the watcher adds newly discovered devices."""
    first = ListSource(stroke(n=5), gate=threading.Event())
    late = ListSource(stroke(n=5), name="late-tablet", gate=threading.Event())
    d = make_daemon(endpoints, {"pen": first})
    present: list[str] = []
    d.hotplug = Hotplug(
        lambda: d.slots,
        lambda s: late,
        use_udev=False,
        discover=lambda: list(present),
        on_ready=d.waker.wake,
    )
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    try:
        with Runner(d):
            assert d.hotplug.scan_once() == 0  # nothing new yet
            present.append("/dev/hidraw7")
            assert d.hotplug.scan_once() == 1
            assert d.hotplug.scan_once() == 0  # not opened twice while it is handed over
            frame = _wait_for(sub, lambda m: m["device"] == "late-tablet")
            assert frame["kind"] == "frame"
            names = [
                x["name"]
                for x in request(ctx, endpoints[1], protocol.make_request("devices"))["devices"]
            ]
            assert names == ["test-pen", "late-tablet"]
            first.gate.set()  # type: ignore[union-attr]
            late.gate.set()  # type: ignore[union-attr]
    finally:
        sub.close()


def test_a_touchpad_defaults_to_relative_mapping(
    evdev_data: Path, endpoints: tuple[str, str]
) -> None:
    """A finger put down anywhere on a touchpad starts at the cursor (display centre)."""
    spec = f"replay:{evdev_data / 'cypress-trackpad.two-finger-press.evemu'}"
    sent = _run_virtual(endpoints, spec)
    frames = [msgpack.unpackb(p) for t, p in sent if t.startswith(protocol.TOPIC_FRAME)]
    first = next(c for f in frames for c in f["contacts"])
    assert first["touch_px"] == pytest.approx([960.0, 540.0])
    assert first["touch_m"] != [0.0, 0.0]


def test_garbage_from_a_driver_is_rejected_and_the_loop_survives(
    endpoints: tuple[str, str],
) -> None:
    good = stroke(n=30)
    garbage: list[Any] = [
        PenSample(t=0.05, x=None, y=0.05, tip=True),  # type: ignore[arg-type]
        PenSample(t="soon", x=0.1, y=0.05, tip=True),  # type: ignore[arg-type]
        PenSample(t=0.06, x=0.1, y=0.05, tip=True, contact="zero"),  # type: ignore[arg-type]
    ]
    samples = good[:10] + garbage + good[10:]
    recorder = Recorder()
    d = make_daemon(endpoints, {"replay:junk": ListSource(samples)}, recorder, clock="virtual")
    sent = recorder.messages
    try:
        assert d.run() == 0
        stats = d.stats()
    finally:
        d.close()
    assert stats["devices"]["test-pen"]["rejected"] == 3
    frames = [msgpack.unpackb(p) for t, p in sent if t.startswith(protocol.TOPIC_FRAME)]
    assert frames[-1]["contacts"][-1]["phase"] == "up"


_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**63 - 1)
    | st.floats()
    | st.text(max_size=20),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=8,
)


@settings(max_examples=150)
@given(
    op=st.sampled_from([*protocol.CONTROL_OPS, "nope", ""]),
    args=st.dictionaries(
        st.sampled_from(["toml", "path", "material", "mu_s", "k", "rate", "x"]), _values, max_size=3
    ),
    raw=st.binary(max_size=64),
)
def test_control_handler_answers_anything_without_raising(
    control_daemon: Daemon, op: str, args: dict[str, Any], raw: bytes
) -> None:
    assert control_daemon.control is not None
    for payload in (raw, msgpack.packb({"v": 1, "op": op, **args})):
        reply = msgpack.unpackb(control_daemon.control.handle(payload))
        assert reply["v"] == 1 and isinstance(reply["ok"], bool)
        if not reply["ok"]:
            assert isinstance(reply["error"], str) and reply["error"]


@pytest.fixture(scope="module")
def control_daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Daemon]:
    tmp = tmp_path_factory.mktemp("ctl")
    d = make_daemon((f"ipc://{tmp}/p", f"ipc://{tmp}/c"), {"pen": ListSource(stroke(n=5))})
    yield d
    d.close()
