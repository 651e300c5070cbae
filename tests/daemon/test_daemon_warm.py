"""The warm pass before each deadline (stiction.daemon.warm) changes no frame.

The loop runs the tick's code on scratch state during its spin; these tests
replay real recordings through the real drivers under the virtual clock with
a warm pass before every tick and without any, and require the published
bytes to be identical."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgpack
import pytest
import zmq

from stiction import protocol
from stiction.daemon.clock import Nap, RealClock, VirtualClock, Warm, Watch
from stiction.daemon.devices import DeviceConfig
from stiction.daemon.options import Options
from stiction.daemon.publisher import Publisher, Recorder
from stiction.daemon.security import CurveConfig, Guard
from stiction.daemon.service import Daemon


class WarmingClock(VirtualClock):
    """The virtual clock, but running the warm pass before every deadline as
    the real clock does in its spin."""

    def __init__(self, start: float) -> None:
        super().__init__(start)
        self.warmed = 0

    def sleep_until(
        self,
        deadline: float,
        warm: Warm | None = None,
        watch: Watch | None = None,
        nap: Nap | None = None,
    ) -> None:
        assert warm is not None, "the loop gave its clock no warm pass"
        warm(deadline)
        self.warmed += 1
        super().sleep_until(deadline)


def _replay(tmp_path: Path, specs: list[str], warm: bool) -> tuple[Recorder, Daemon, int]:
    o = Options(
        pub=f"ipc://{tmp_path}/pub", control=f"ipc://{tmp_path}/ctl", clock="virtual",
        hotplug=False, devices=[DeviceConfig(s) for s in specs],
    )  # fmt: skip
    recorder = Recorder()
    d = Daemon(o, publisher=recorder)
    d.warm_spin = warm
    d.open()
    clock = WarmingClock(d.clock.now())
    if warm:
        d.clock = clock
    try:
        assert d.run() == 0
    finally:
        d.close()
    return recorder, d, clock.warmed


@pytest.mark.parametrize(
    "recordings",
    [
        ["uc-logic-wp5540u-pen.evemu"],
        # two devices, one a multi-touch touchpad (relative mapping)
        ["wacom-cintiq-13hd-touch-pen.evemu", "cypress-trackpad.two-finger-press.evemu"],
    ],
)
def test_a_warmed_replay_publishes_the_same_bytes_as_an_unwarmed_one(
    evdev_data: Path, tmp_path: Path, recordings: list[str]
) -> None:
    specs = [f"replay:{evdev_data / r}" for r in recordings]
    plain, _, none = _replay(tmp_path, specs, warm=False)
    warmed, d, passes = _replay(tmp_path, specs, warm=True)
    assert none == 0 and plain.warmed == 0
    frames = [p for t, p in warmed.messages if t.startswith(protocol.TOPIC_FRAME)]
    ticks = d.schedule.ticks
    assert ticks > 50
    # The warm pass ran before every tick, through the publisher's warm for
    # every open device, and its scratch contacts did reach the send path.
    assert passes == ticks
    assert warmed.warmed >= ticks
    assert any(msgpack.unpackb(p)["contacts"] for p in frames)
    assert warmed.messages == plain.messages


def test_a_failing_warm_pass_turns_itself_off_and_the_loop_goes_on(
    evdev_data: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    spec = f"replay:{evdev_data / 'uc-logic-wp5540u-pen.evemu'}"
    plain, _, _ = _replay(tmp_path, [spec], warm=False)

    class Broken(Recorder):
        def warm(self, topic: bytes, message: Any) -> None:
            raise RuntimeError("warm broke")

    o = Options(
        pub=f"ipc://{tmp_path}/pub", control=f"ipc://{tmp_path}/ctl", clock="virtual",
        hotplug=False, devices=[DeviceConfig(spec)],
    )  # fmt: skip
    broken = Broken()
    d = Daemon(o, publisher=broken)
    d.open()
    d.clock = WarmingClock(d.clock.now())
    try:
        assert d.run() == 0
    finally:
        d.close()
    assert broken.messages == plain.messages
    assert [r for r in caplog.records if "warm_failed" in r.getMessage()]


def test_the_zeromq_publisher_warms_without_sending_anything(tmp_path: Path) -> None:
    ctx: zmq.Context[Any] = zmq.Context()
    guard = Guard(ctx, CurveConfig())
    pub = Publisher(ctx, f"ipc://{tmp_path}/pub", guard, 1000)
    sub = ctx.socket(zmq.SUB)
    try:
        sub.setsockopt(zmq.SUBSCRIBE, b"")
        sub.connect(pub.endpoint)
        assert pub.wait_subscribers(1, 10.0) == 1
        frame = protocol.frame(0, -1, 1.0, None, "pen", [])
        for _ in range(50):
            pub.warm(protocol.frame_topic("pen"), frame)
        pub.send(protocol.frame_topic("pen"), {**frame, "tick": 1})
        assert sub.poll(10_000)
        topic, payload = sub.recv_multipart()
        assert (topic, msgpack.unpackb(payload)["tick"]) == (b"frame.pen", 1)
        assert not sub.poll(100)
        assert (pub.sent, pub.dropped) == (1, 0)
    finally:
        sub.close(0)
        pub.close()
        guard.close()
        ctx.term()


def test_the_real_clock_skips_the_warm_pass_when_the_deadline_has_passed() -> None:
    calls: list[float] = []
    clock = RealClock(0.0003)
    clock.sleep_until(clock.now() - 1.0, calls.append)
    assert (calls, clock.warmed, clock.warm_skipped) == ([], 0, 1)


def test_without_a_spin_the_real_clock_never_warms() -> None:
    calls: list[float] = []
    clock = RealClock(0.0)
    clock.sleep_until(clock.now() - 1.0, calls.append)
    assert (calls, clock.warmed, clock.warm_skipped) == ([], 0, 0)


class FakeTime:
    """time.monotonic and time.sleep on a hand-driven clock; the poll loop
    advances it by `poll` per call so that spinning ends."""

    def __init__(self, now: float = 100.0, overshoot: float = 0.0, poll: float = 1e-5) -> None:
        self.now = now
        self.overshoot = overshoot
        self.poll = poll
        self.slept: list[float] = []

    def monotonic(self) -> float:
        self.now += self.poll
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += seconds + self.overshoot

    def thread_time(self) -> float:
        return self.now  # the thread runs all the time it is not sleeping


def test_the_real_clock_learns_the_warm_pass_and_wakes_that_much_earlier(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import stiction.daemon.clock as clock_module

    fake = FakeTime()
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)
    started: list[float] = []

    def warm(deadline: float) -> None:
        started.append(deadline - fake.now)  # how long before the deadline it began
        fake.now += 0.0002  # the pass takes 0.2 ms

    deadline = 101.0
    for k in range(200):
        clock.sleep_until(deadline + k * 0.01, warm)
    assert clock.warmed == 200 and clock.warm_skipped == 0
    assert clock.warm_s == pytest.approx(0.0002, abs=2e-5)  # + one poll step of the fake clock
    # It now wakes spin + pass before the deadline, so the pass begins about
    # 0.5 ms before it and the polling still has the spin's 0.3 ms after it.
    assert started[-1] == pytest.approx(0.0005, abs=3e-5)
    assert started[0] == pytest.approx(0.0003, abs=3e-5)
    assert fake.now >= deadline + 199 * 0.01  # never returns before the deadline


def test_a_wake_up_too_late_for_the_pass_skips_it_and_a_stall_counts_as_1_ms(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import stiction.daemon.clock as clock_module

    fake = FakeTime(overshoot=0.00028)  # the sleep comes back 0.28 ms late
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)
    calls: list[float] = []
    clock.sleep_until(101.0, calls.append)
    assert (calls, clock.warmed, clock.warm_skipped) == ([], 0, 1)

    fake.overshoot = 0.0

    def stalled(deadline: float) -> None:
        fake.now += 0.05  # preempted for 50 ms inside the pass

    clock.sleep_until(102.0, stalled)
    assert clock.warmed == 1
    assert (clock.overrun, clock.overran) == (0.0, 0)  # a warm pass's stall is lateness
    assert clock.warm_s == pytest.approx(clock_module.WARM_CAP_S * clock_module.WARM_EMA)


def test_a_preparation_runs_on_a_late_wake_up_and_its_part_past_the_deadline_is_recorded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A pass given with a watch prepares the tick itself (stiction.daemon.prepare):
    a wake-up too late for a warm pass still runs it, and the time it runs
    past the deadline is kept for the loop to count as the tick's work."""
    import stiction.daemon.clock as clock_module

    fake = FakeTime(overshoot=0.00028)  # back 0.28 ms late: 0.02 ms before the deadline
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)
    watched: list[float] = []

    def prepare(deadline: float) -> None:
        fake.now += 0.0001  # the preparation takes 0.1 ms

    clock.sleep_until(101.0, prepare, lambda d, now: watched.append(now))
    assert (clock.warmed, clock.warm_skipped) == (1, 0)
    assert clock.overrun == pytest.approx(0.0001 - 0.00002, abs=3e-5)
    assert 0 < clock.overrun_cpu <= clock.overrun + 1e-9
    assert watched == []  # past the deadline: no polling, no watch

    fake.overshoot = 0.0
    clock.sleep_until(102.0, prepare, lambda d, now: watched.append(now))
    assert clock.overrun == 0.0 and clock.overrun_cpu == 0.0
    assert watched and all(now < 102.0 for now in watched)

    fake.now = 103.5  # woken after the deadline: nothing to prepare for
    clock.sleep_until(103.0, prepare, lambda d, now: None)
    assert (clock.warmed, clock.warm_skipped) == (2, 1)


def test_a_watch_whose_work_runs_past_the_deadline_is_recorded_as_the_ticks(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The preparation redone in the spin (stiction.daemon.prepare) may start
    just before the deadline; what it spends past it is the tick's work."""
    import stiction.daemon.clock as clock_module

    fake = FakeTime()
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)
    calls: list[float] = []

    def prepare(deadline: float) -> None:
        fake.now += 0.0001

    def redo_late(deadline: float, now: float) -> bool:
        calls.append(now)
        if deadline - now < 0.00005:  # input just before the deadline: redo it
            fake.now += 0.00006
            return True
        return False

    clock.sleep_until(101.0, prepare, redo_late)
    assert clock.overran == 1
    assert 0.00001 <= clock.overrun <= 0.00006 and clock.overrun_cpu == clock.overrun

    def idle(deadline: float, now: float) -> bool:
        return False

    clock.sleep_until(102.0, prepare, idle)
    assert (clock.overrun, clock.overran) == (0.0, 1)


def test_after_a_preparation_the_polling_sleeps_in_short_steps_then_spins(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A reader gets the interpreter while the deadline is far, and the last
    YIELD_UNTIL_S is a spin, so the loop still leaves it on time."""
    import stiction.daemon.clock as clock_module

    fake = FakeTime(poll=1e-6)
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)
    left: list[float] = []

    def watch(deadline: float, now: float) -> bool:
        left.append(deadline - now)
        return False

    clock.sleep_until(101.0, lambda d: None, watch)
    naps = fake.slept[1:]  # after the sleep to the spin
    assert len(naps) >= 5 and set(naps) == {clock_module.YIELD_S}
    assert min(left) < clock_module.YIELD_UNTIL_S / 10  # spun to the end
    assert fake.now >= 101.0

    fake.slept.clear()
    clock.sleep_until(102.0)  # no preparation: a bare spin, no naps
    assert len(fake.slept) == 1


def test_with_a_nap_the_preparation_comes_ahead_of_the_spin_and_the_nap_fills_the_gap(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Given a nap (the loop's prepared tick, Daemon.prepare_ahead), the clock
    wakes the learnt lateness allowance before the spin and the preparation,
    prepares, naps until the spin, and polls from there as before."""
    import stiction.daemon.clock as clock_module

    fake = FakeTime(poll=1e-6)
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)
    began: list[float] = []
    naps: list[tuple[float, float]] = []

    def prepare(deadline: float) -> None:
        began.append(deadline - fake.now)
        fake.now += 0.0002

    def nap(seconds: float) -> None:
        naps.append((101.0 - fake.now, seconds))
        fake.now += seconds

    clock.sleep_until(101.0, prepare, lambda d, now: False, nap)
    # woken late_s (1 ms at first) + spin before the deadline, the preparation's
    # duration not learnt yet
    assert began[0] == pytest.approx(clock_module.LATE_INIT_S + 0.0003, abs=1e-5)
    # one nap, from the end of the preparation to the spin
    assert len(naps) == 1
    left, seconds = naps[0]
    assert left - seconds == pytest.approx(0.0003, abs=1e-5)
    assert fake.now >= 101.0 and clock.overrun == 0.0
    assert all(s == clock_module.YIELD_S for s in fake.slept[1:])  # the spin's short sleeps


def test_a_nap_ended_by_input_redoes_the_tick_then_and_naps_again(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import stiction.daemon.clock as clock_module

    fake = FakeTime(poll=1e-6)
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)
    arrived = [False]
    redone: list[float] = []

    def nap(seconds: float) -> None:
        if not redone:  # input 0.2 ms into the first nap ends it
            fake.now += 0.0002
            arrived[0] = True
        else:
            fake.now += seconds

    def watch(deadline: float, now: float) -> bool:
        if arrived[0]:
            arrived[0] = False
            redone.append(deadline - now)
            fake.now += 0.0001
            return True
        return False

    clock.sleep_until(101.0, lambda d: None, watch, nap)
    assert len(redone) == 1 and redone[0] > 0.0005  # long before the deadline
    assert clock.overrun == 0.0 and clock.overran == 0


def test_the_lead_learns_how_late_the_wake_up_comes(monkeypatch: pytest.MonkeyPatch) -> None:
    """The allowance settles near a high quantile of the wake-up's lateness,
    within its bounds."""
    import stiction.daemon.clock as clock_module

    fake = FakeTime(poll=1e-6)
    monkeypatch.setattr(clock_module, "time", fake)
    clock = RealClock(0.0003)

    def nap(seconds: float) -> None:
        fake.now += seconds

    fake.overshoot = 0.0001  # every sleep 0.1 ms late
    for k in range(4000):
        clock.sleep_until(101.0 + k * 0.01, lambda d: None, lambda d, now: False, nap)
    assert clock.late_s == pytest.approx(clock_module.LATE_MIN_S)
    fake.overshoot = 0.005  # every sleep 5 ms late: as far as the bound allows
    for _ in range(200):
        clock.sleep_until(fake.now + 0.01, lambda d: None, lambda d, now: False, nap)
    assert clock.late_s == pytest.approx(clock_module.LATE_MAX_S)
    assert clock.warm_skipped > 0  # those wake-ups came after their deadlines
