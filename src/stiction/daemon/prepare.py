"""The coming tick computed before its deadline, and sent at it if nothing changed.

A live tick's frame depends on what its device delivered by the deadline.
Most ticks, nothing more arrives in the last half millisecond before it: a
tablet reports every 5 ms or so, and the loop is already awake then,
spinning to the deadline (stiction.daemon.clock). `Preparer.prepare` runs
there, in place of the warm pass: for each device it takes what has
arrived so far (stiction.daemon.devices.select_live, which takes nothing
away), steps a copy of the device's contact state through the current
pipeline (Pipeline.fork), builds the frame and encodes it. Nothing the
loop reads is changed, except that the reader's queue is moved to the
slot's pending samples, which the tick would do first anyway in the same
order (devices.drain_live).

While the clock then polls, `Preparer.watch` looks at the prepared
devices' queues and prepares a device again when a sample arrived.

At the deadline, `Preparer.claim` hands the loop a device's prepared tick
if it still holds: no sample arrived since (nothing queued stamped by
the deadline: a tick takes only what arrived by it, devices.drain_live),
the device did not go away, and the slot's contact state, mapping and the
pipeline are the objects it was computed from (a reopened device, a scene
or parameter change replace them). The loop then commits it (the pending
samples it took, the stepped copy as the device's state) and sends the
bytes already encoded. Otherwise it is dropped and the loop runs the
ordinary tick: a sample that arrived by the deadline after the last turn
of the polling, even one whose mapped time is after the deadline, still
moves the device clock's offset, and with it the times of the samples the
tick takes, so any such arrival makes a miss.

`Preparer.nap` is for an experiment, off by default (service.Daemon's
`prepare_ahead`): the clock prepares well ahead of the spin and naps to
it, and the nap ends when a sample arrives so that `watch` redoes the
tick at once.

A device whose mapping has no affine form (a touchpad's relative mapping
keeps a cursor) is not prepared; it, and a device going away, get the warm
pass instead (stiction.daemon.warm). Frames are byte for byte those of a
loop that never prepares: tests/daemon/test_daemon_prepare.py drives both
on a scripted clock with samples arriving before and after the
preparation and stamped after the deadline, contacts starting and
ending, a device leaving and coming back, and a parameter change after a
preparation.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, Protocol

from stiction import protocol
from stiction.daemon import warm
from stiction.daemon.clock import Clock, Schedule
from stiction.daemon.devices import DeviceSlot, Taken, commit_live, drain_live, select_live
from stiction.daemon.wake import Waker
from stiction.daemon.warm import Warmer
from stiction.scene.pipeline import DeviceRun, Pipeline

log = logging.getLogger("stiction.daemon.prepare")


@dataclass(eq=False, slots=True)
class Prepared:
    """One device's tick, computed before its deadline and not committed."""

    tick: int
    t: float
    prev_t: float
    run: DeviceRun
    """The slot's contact state it was computed from."""
    mapping: Any
    pipeline: Pipeline
    sent_tick: int
    taken: Taken
    fork: DeviceRun
    """`run` stepped to `t`: the device's state once committed."""
    frame: protocol.FrameWire
    topic: bytes
    payload: bytes | None
    """The encoded frame (None: the publisher takes messages only)."""
    quiet: bool
    """The slot's `quiet` after this tick (service.Daemon._tick says what it means)."""

    def commit(self, slot: DeviceSlot) -> None:
        """Make the prepared tick the slot's: its samples taken, its state stepped."""
        commit_live(slot, self.taken)
        Pipeline.adopt(self.run, self.fork)


class Loop(warm.Loop, Protocol):
    """What the preparation reads of the daemon (stiction.daemon.service.Daemon):
    what the warm pass reads, and the schedule and the last frames."""

    @property
    def schedule(self) -> Schedule: ...
    @property
    def last_tick_t(self) -> float: ...
    @property
    def last_frames(self) -> dict[str, protocol.FrameWire]: ...
    @property
    def waker(self) -> Waker: ...
    @property
    def clock(self) -> Clock: ...


class Preparer:
    """Prepares each tick during the spin; counts how often a preparation held."""

    def __init__(self, daemon: Loop, warmer: Warmer | None = None) -> None:
        """`warmer`: the warm pass for the devices that are not prepared."""
        self.daemon = daemon
        self.warmer = warmer
        self.prepared: dict[int, Prepared | None] = {}
        """By id of the slot, for the coming deadline only (None: dropped in the spin)."""
        self.enabled = True
        self.hits = 0
        """Device ticks sent as prepared."""
        self.misses = 0
        """Device ticks prepared, then run afresh (input arrived, something changed)."""
        self.unprepared = 0
        """Device ticks with nothing prepared (no spin before them, a relative
        mapping, a device going away, a failed step)."""
        self.redone = 0
        """Preparations redone in the spin because input arrived after them."""
        self.watched: list[DeviceSlot] = []
        """The slots prepared for the coming deadline."""
        self.rehearsal = True
        """Rehearse the deadline's work at the end of a full nap (`nap`)."""
        self.rehearsals = 0
        """Prepared device ticks rehearsed (a statistic for tests and benches)."""

    def prepare(self, t: float) -> None:
        """Prepare every device's tick for the deadline `t`; never raises.

        The clock calls this at the start of its spin (clock.Warm). A
        failure is a bug (the copies are ours alone): it turns preparing off
        for good, logged once, and the loop goes on with ordinary ticks."""
        self.prepared.clear()
        self.watched.clear()
        rest: list[DeviceSlot] | None = None
        if self.enabled:
            try:
                rest = self._prepare(t)
            except Exception:
                self.enabled = False
                self.prepared.clear()
                log.exception("prepare_failed (the loop goes on with ordinary ticks)")
        if self.warmer is not None and rest != []:
            self.warmer.warm(t, rest)

    def _prepare(self, t: float) -> list[DeviceSlot]:
        """Prepare what can be; returns the open slots that were not."""
        d = self.daemon
        rest: list[DeviceSlot] = []
        watched = self.watched
        watched.clear()
        for slot in d.slots:
            if slot.run is None:
                continue
            if self._prepare_slot(slot, t, warm=True):
                watched.append(slot)
            else:
                rest.append(slot)
        return rest

    def _prepare_slot(self, slot: DeviceSlot, t: float, warm: bool) -> bool:
        """Prepare one device's tick at `t`; False if it cannot be (it gets the
        warm pass then, or meets its problem again in the ordinary tick)."""
        d = self.daemon
        run = slot.run
        pipeline = d.pipeline
        fork = None if slot.went_away else pipeline.fork(run)
        if fork is None:
            return False
        prev_t = d.last_tick_t
        drain_live(slot, t)
        taken = select_live(slot, prev_t, t)
        try:
            contacts = pipeline.step(fork, t, prev_t, taken.samples)
        except Exception:
            return False  # the ordinary tick meets it again, and handles and logs it there
        last = d.last_frames.get(slot.name)
        quiet = not taken.samples and not contacts and last is not None and not last["contacts"]
        t_input = taken.last_t if math.isfinite(taken.last_t) else None
        tick = d.schedule.ticks
        frame = protocol.frame(tick, slot.sent_tick, t, t_input, slot.name, contacts)
        topic = protocol.frame_topic(slot.name)
        pub = d.publisher
        payload = protocol.encode(frame) if hasattr(pub, "send_payload") else None
        if warm and payload is not None:
            send = getattr(pub, "warm_payload", None)
            if send is not None:
                send(topic, payload)  # the send path, warm for the real send
        self.prepared[id(slot)] = Prepared(
            tick, t, prev_t, run, run.mapping, pipeline, slot.sent_tick, taken, fork,
            frame, topic, payload, quiet,
        )  # fmt: skip
        return True

    def watch(self, deadline: float, now: float) -> bool:
        """Redo a prepared tick whose device delivered since; called on every
        turn of the spin's polling (clock.Watch), so it returns at once when
        nothing arrived. True if it redid one.

        A redo runs with the caches the preparation warmed: in a scratch run
        (synthetic:demo, no subscribers, 1000 ticks, load average 1.0) a
        second preparation right after the first took 64 us (p50), 126
        (p90), 187 (p99), where the first took 352 us (p50). So it is done
        however little time is left: the ordinary tick it spares would do
        the same work after the deadline, and the clock counts the redo's
        part past the deadline as the tick's work."""
        for slot in self.watched:
            if _arrived(slot, deadline):
                self._redo(slot, deadline)
                return True
        return False

    def nap(self, seconds: float) -> None:
        """Sleep up to `seconds`, ended early by a sample for any device (its
        reader wakes the daemon's waker); the clock calls this between an
        early preparation and the spin (clock.Nap), then `watch` redoes the
        device at once, with the deadline still well ahead.

        The waker is the idle loop's (stiction.daemon.wake): armed before
        the queues are looked at, so an arrival in between is not slept
        through; a control request or a hot-plug also ends the nap, and the
        clock naps again. These wake-ups are not counted as idle ones.

        A nap that runs its length ends with a rehearsal of the deadline's
        work (`rehearse`): the nap left the caches cold again."""
        waker = self.daemon.waker
        waker.arm(count=False)
        try:
            for slot in self.watched:
                if slot.queue:
                    return
            woken = waker.nap(seconds)
        finally:
            waker.disarm()
        if not woken and self.rehearsal:
            self.rehearse()

    def rehearse(self) -> None:
        """Run what the deadline will run for each prepared device, without
        its effects: the claim's checks, and the send of the encoded frame
        through the socket with no peer (the publisher's warm_payload)."""
        send = getattr(self.daemon.publisher, "warm_payload", None)
        now = self.daemon.clock.now()
        for slot in self.watched:
            p = self.prepared.get(id(slot))
            if p is None or now >= p.t or not self._holds(slot, p, p.tick, p.t, p.prev_t):
                continue  # (a nap that overslept the deadline: the real thing is due)
            if send is not None and p.payload is not None:
                send(p.topic, p.payload)
            self.rehearsals += 1

    def _redo(self, slot: DeviceSlot, t: float) -> None:
        self.watched.remove(slot)
        try:
            done = self.enabled and self._prepare_slot(slot, t, warm=False)
        except Exception:
            self.enabled = False
            self.prepared.clear()
            log.exception("prepare_failed (the loop goes on with ordinary ticks)")
            return
        if done:
            self.watched.append(slot)
            self.redone += 1
        else:
            # What was prepared lacks what arrived: the tick runs afresh.
            self.prepared[id(slot)] = None

    def claim(self, slot: DeviceSlot, tick: int, t: float, prev_t: float) -> Prepared | None:
        """The slot's prepared tick if it still holds at the deadline, else None.

        Checks only what can have changed since `prepare`: a sample queued,
        the device gone, the slot's contact state, mapping or the pipeline
        replaced. The caller commits what it is given."""
        key = id(slot)
        if key not in self.prepared:
            self.unprepared += 1
            return None
        p = self.prepared.pop(key)
        if p is None or not self._holds(slot, p, tick, t, prev_t):
            self.misses += 1
            return None
        self.hits += 1
        return p

    def _holds(self, slot: DeviceSlot, p: Prepared, tick: int, t: float, prev_t: float) -> bool:
        run = slot.run
        return not (
            _arrived(slot, t)
            or slot.went_away
            or p.run is not run
            or p.mapping is not run.mapping
            or p.pipeline is not self.daemon.pipeline
            or p.tick != tick
            or p.t != t
            or p.prev_t != prev_t
            or p.sent_tick != slot.sent_tick
        )


def _arrived(slot: DeviceSlot, t: float) -> bool:
    """A sample is queued that the tick at `t` would take in (drain_live:
    one that arrived by `t`; the reader's queue is in arrival order)."""
    q = slot.queue
    return bool(q) and q[0][1] <= t
