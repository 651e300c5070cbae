"""The prepared tick (stiction.daemon.prepare) publishes the bytes of the ordinary one.

The live loop computes each tick during its spin and sends it as computed at
the deadline when nothing changed in between. These tests drive the live
loop (take_live, the reader queues, the prepared path) on a scripted clock:
the script puts each sample in its device's queue at its arrival time, some
before the preparation and some between it and the deadline, takes a device
away and brings it back, and changes the parameters after a preparation.
The same script runs with preparation and without; every published message
must be the same, byte for byte, and both outcomes of a preparation (sent,
dropped) must have happened.
"""

from __future__ import annotations

import math
import queue
import random
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgpack
import pytest
from daemon_support import stroke

from stiction import protocol
from stiction.daemon.clock import Nap, Warm, Watch
from stiction.daemon.devices import DeviceConfig, DeviceSlot, Spec
from stiction.daemon.mapping import MappingConfig
from stiction.daemon.options import Options
from stiction.daemon.publisher import Recorder
from stiction.daemon.service import Daemon
from stiction.drivers.sample import PenSample
from stiction.errors import DeviceError

START = 100.0
"""Loop time of deadline 0."""
RATE = 100.0
TICKS = 150
LEADS = (0.0005, 0.002, 0.004)
"""How long before each deadline the script's clock runs the preparation,
one of these for each deadline (seeded): at the start of the spin, or
ahead of it, napping to it (clock.RealClock with a nap)."""
LEAD = LEADS[0]
"""The shortest: events the script places "after the preparation" are
after it whichever lead a deadline gets."""


class HeldSource:
    """A device whose reader blocks until the test ends it: its samples are
    put in the slot's queue by the script, at their arrival times."""

    def __init__(self, name: str) -> None:
        self._name = name
        self.release = threading.Event()
        self.gone = False

    @property
    def name(self) -> str:
        return self._name

    @property
    def surface_size(self) -> tuple[float, float]:
        return (0.2, 0.1)

    @property
    def kind(self) -> str:
        return "pen"

    def samples(self) -> Iterator[PenSample]:
        self.release.wait(60)
        if self.gone:
            raise DeviceError(f"{self._name} was unplugged")
        yield from ()

    def unplug(self) -> None:
        self.gone = True
        self.release.set()

    def close(self) -> None:
        self.release.set()

    def stats(self) -> dict[str, int]:
        return {}


class Watcher:
    """The hot-plug watcher's face to the loop: reopened devices in `ready`."""

    def __init__(self) -> None:
        self.ready: queue.SimpleQueue[tuple[DeviceSlot, Any]] = queue.SimpleQueue()

    def installed(self, slot: DeviceSlot) -> None:
        pass

    def stop(self) -> None:
        pass


@dataclass(order=True)
class Event:
    at: float
    """Loop time it happens at."""
    seq: int
    act: Callable[[Daemon], None] = field(compare=False)


class ScriptedClock:
    """A live loop's clock on scripted time: before each deadline it plays the
    events due by the preparation, runs the preparation, plays the events due
    by the deadline, and returns on it."""

    virtual = False

    def __init__(self, d: Daemon, events: list[Event], seed: int = 7) -> None:
        self.d = d
        self.events = sorted(events)
        self._now = START - 1.0
        self.prepared = 0
        self.naps = 0
        self._leads = random.Random(seed)
        self.after: list[float] = []
        """Arrival stamps queued before the tick of the deadline they follow ran."""

    def now(self) -> float:
        return self._now

    def _play(self, until: float) -> None:
        while self.events and self.events[0].at <= until:
            self.events.pop(0).act(self.d)

    def sleep_until(
        self,
        deadline: float,
        warm: Warm | None = None,
        watch: Watch | None = None,
        nap: Nap | None = None,
    ) -> None:
        lead = self._leads.choice(LEADS)
        self._play(deadline - lead)
        self._now = max(self._now, deadline - lead)
        if warm is not None:
            warm(deadline)
            self.prepared += 1
        # Between the preparation and the deadline, each event at its time,
        # and the spin's watch after it, as the polling would; an event at
        # the deadline itself comes after the polling's last look. With a
        # nap, the loop naps until each event (a wait that ends at once here).
        while self.events and self.events[0].at <= deadline:
            event = self.events.pop(0)
            if nap is not None and self._now < event.at:
                nap(0.0)
                self.naps += 1
            self._now = max(self._now, event.at)
            event.act(self.d)
            if watch is not None and self._now < deadline:
                watch(deadline, self._now)
        self._now = max(self._now, deadline)


def _slot(d: Daemon, name: str) -> DeviceSlot:
    return next(s for s in d.slots if s.config.spec == name)


def _arrivals(
    device: str, samples: list[PenSample], seed: int, t0: float, after: list[float]
) -> list[Event]:
    """Each sample queued at its device time + `t0` + a delivery delay of 0.2-3 ms,
    in order (a reader hands them over one after the other); one due in the
    last 0.1 ms before a deadline arrives on the deadline, after the spin's
    last look at the queue; one stamped in the first 0.5 ms after a deadline
    is queued before that deadline's tick runs (a tick a little late), and
    must wait for the next tick (devices.drain_live); their stamps are
    added to `after`."""
    rng = random.Random(seed)
    out: list[Event] = []
    at = -1.0
    for s in samples:
        at = max(at, t0 + s.t + rng.uniform(0.0002, 0.003))
        k = math.ceil((at - START) * RATE)
        if START + k / RATE - at < 0.0001:
            at = START + k / RATE
        play = at
        if 0.0 < at - (START + (k - 1) / RATE) <= 0.0005:
            play = START + (k - 1) / RATE
            after.append(at)

        def put(d: Daemon, s: PenSample = s, at: float = at) -> None:
            _slot(d, device).queue.append((s, at))

        out.append(Event(play, 0, put))
    return out


def _two_contacts(t0: float, n: int) -> list[PenSample]:
    """Contact 0's stroke and contact 1's shorter one inside it, in time order."""
    both = stroke(t0, n=n, dt=0.004) + stroke(t0 + 0.2, n=n // 3, dt=0.004, speed=-0.03, contact=1)
    return sorted(both, key=lambda s: s.t)


def _script(sources: dict[str, list[HeldSource]], after: list[float]) -> list[Event]:
    """The run's events: two devices' strokes, the pen unplugged mid-contact
    and plugged back, a parameter change between a preparation and its deadline."""
    pen = [s for s in _two_contacts(0.0, 200) if s.t < 0.69]
    events = _arrivals("pen", pen, 1, START, after)
    events += _arrivals("pad", stroke(0.1, n=180, dt=0.004), 2, START, after)
    unplug_at = START + 0.70 - LEAD / 3  # after the preparation for 0.70, before its deadline

    def unplug(d: Daemon) -> None:
        slot = _slot(d, "pen")
        sources["pen"][0].unplug()
        assert slot.thread is not None
        slot.thread.join(10)  # the reader has marked it gone
        assert slot.went_away

    def replug(d: Daemon) -> None:
        back = HeldSource("pen")
        sources["pen"].append(back)
        d.hotplug.ready.put((_slot(d, "pen"), back))

    def change(d: Daemon) -> None:
        d.set_params({"mu_k": 0.3, "k": 0.15}, None)

    events.append(Event(unplug_at, 1, unplug))
    events.append(Event(START + 0.85 - LEAD / 3, 1, replug))
    events += _arrivals("pen", stroke(0.0, n=80, dt=0.004), 3, START + 0.87, after)
    events.append(Event(START + 0.40 - LEAD / 3, 1, change))
    return events


def _run(
    tmp_path: Path, prepare: bool, ahead: bool = True
) -> tuple[Recorder, Daemon, ScriptedClock]:
    sources: dict[str, list[HeldSource]] = {"pen": [HeldSource("pen")], "pad": [HeldSource("pad")]}
    relative = MappingConfig(mode="relative")
    o = Options(
        pub=f"ipc://{tmp_path}/pub", control=f"ipc://{tmp_path}/ctl", hotplug=False,
        keepalive=0, start=START, seconds=TICKS / RATE, rate=RATE,
        devices=[DeviceConfig("pen"), DeviceConfig("pad", mapping=relative, mapping_given=True)],
    )  # fmt: skip

    def opener(spec: Spec, cfg: DeviceConfig, realtime: bool, loop: bool) -> HeldSource:
        return sources[cfg.spec][-1]

    recorder = Recorder()
    d = Daemon(o, opener=opener, publisher=recorder)
    d.prepare_spin = prepare
    d.prepare_ahead = ahead
    d.open()
    d.hotplug = Watcher()
    clock = ScriptedClock(d, [])
    clock.events = sorted(_script(sources, clock.after))
    d.clock = clock
    try:
        assert d.run() == 0
    finally:
        d.close()
    return recorder, d, clock


@pytest.mark.parametrize("ahead", [True, False])
def test_prepared_ticks_publish_the_bytes_of_ordinary_ones(tmp_path: Path, ahead: bool) -> None:
    plain, d0, _ = _run(tmp_path, prepare=False)
    prepared, d, clock = _run(tmp_path, prepare=True, ahead=ahead)
    assert d0.preparer is None
    assert d.schedule.ticks == d0.schedule.ticks == TICKS
    assert clock.prepared == TICKS
    # Ahead of the spin the loop naps between the preparation and the spin
    # (here until each event); without, it never does.
    assert (clock.naps > 50) if ahead else (clock.naps == 0)
    assert d.preparer is not None
    assert (d.preparer.rehearsals > 50) if ahead else (d.preparer.rehearsals == 0)
    # Samples stamped just after a deadline, queued before its tick ran, were
    # in the script (they wait for the next tick in both runs).
    assert len(clock.after) >= 3
    frames = [msgpack.unpackb(p) for t, p in plain.messages if t.startswith(protocol.TOPIC_FRAME)]
    pen = [f for f in frames if f["device"] == "pen"]
    # What the script was to bring about did happen: both contacts of the pen
    # began and ended, the pen's contact ended "up" when it was unplugged,
    # and it came back with a new stroke.
    phases = {(c["id"], c["phase"]) for f in pen for c in f["contacts"]}
    touching = {(i, p) for i in (0, 1) for p in ("stick", "slip")}
    assert {0, 1} == {i for i, p in phases & touching}
    assert {(0, "up"), (1, "up")} <= phases
    assert any(f["t"] == START + 0.70 and f["contacts"] for f in pen)
    assert any(f["t"] > START + 0.9 and f["contacts"] for f in pen)
    assert d.slots[0].reopened == 1
    # Every outcome happened: sent as prepared, prepared again in the spin for
    # a sample that arrived after the preparation, dropped for one that
    # arrived after the spin's last look, for the unplugging and for the
    # parameter change; the relative-mapped pad was never prepared.
    stats = d.stats()
    hits, misses, none = stats["prepared_hits"], stats["prepared_misses"], stats["unprepared"]
    assert d.preparer is not None
    assert hits > 100 and misses >= 3 and d.preparer.redone > 5
    assert none >= TICKS  # the pad's ticks, and the pen's while unplugged
    assert hits + misses + none == sum(1 for t, _ in prepared.messages if t != protocol.TOPIC_SCENE)
    assert prepared.messages == plain.messages


def test_a_failing_preparation_turns_itself_off_and_the_loop_goes_on(
    tmp_path: Path, monkeypatch: Any
) -> None:
    from stiction.scene.pipeline import Pipeline

    plain, _, _ = _run(tmp_path, prepare=False)

    def broken(self: Pipeline, dev: Any) -> Any:
        raise RuntimeError("fork broke")

    monkeypatch.setattr(Pipeline, "fork", broken)
    got, d, _ = _run(tmp_path, prepare=True)
    assert d.preparer is not None and not d.preparer.enabled
    assert d.preparer.hits == 0
    assert got.messages == plain.messages


def test_a_redo_that_fails_in_the_spin_leaves_the_tick_to_run_afresh(
    tmp_path: Path, monkeypatch: Any
) -> None:
    """A redo that took the new samples in and then could not finish (its step
    failed, say) must not leave the earlier preparation to be sent."""
    from stiction.daemon import prepare

    plain, _, _ = _run(tmp_path, prepare=False)
    real = prepare.Preparer._prepare_slot
    failed: list[int] = []

    def failing_redo(self: Any, slot: DeviceSlot, t: float, warm: bool) -> bool:
        if warm:
            return real(self, slot, t, warm)
        prepare.drain_live(slot)  # as far as a redo gets before its step
        failed.append(1)
        return False

    monkeypatch.setattr(prepare.Preparer, "_prepare_slot", failing_redo)
    got, d, _ = _run(tmp_path, prepare=True)
    assert d.preparer is not None and d.preparer.redone == 0
    assert len(failed) > 5 and d.preparer.misses >= len(failed)
    assert got.messages == plain.messages


def test_a_sample_stamped_after_the_deadline_waits_and_leaves_the_prepared_tick_standing(
    tmp_path: Path, monkeypatch: Any
) -> None:
    """A tick takes what arrived by its deadline (devices.drain_live): a sample
    the reader stamped after it, queued before the tick ran, is left for the
    next tick by the ordinary tick, and does not drop the prepared one."""
    from stiction.daemon import prepare
    from stiction.daemon.devices import take_live

    slot = DeviceSlot(config=DeviceConfig("pen"), spec=Spec("synthetic", "demo"), name="pen")
    early, late = stroke(0.0, n=2)[:2]
    slot.queue.extend([(early, 9.999), (late, 10.0001)])
    samples, newest = take_live(slot, 9.99, 10.0)
    assert len(samples) == 1 and newest == 9.999
    assert [a for _, a in slot.queue] == [10.0001]

    real = prepare.Preparer.claim
    standing: list[bool] = []

    def claim(self: Any, slot: DeviceSlot, tick: int, t: float, prev_t: float) -> Any:
        queued = bool(slot.queue)
        got = real(self, slot, tick, t, prev_t)
        if queued:
            standing.append(got is not None)
        return got

    monkeypatch.setattr(prepare.Preparer, "claim", claim)
    _, _, clock = _run(tmp_path, prepare=True)
    assert clock.after and any(standing)
