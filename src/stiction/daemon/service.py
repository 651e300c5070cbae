"""The daemon: devices in, one scene pipeline, frames out, at a fixed rate.

`Daemon.run` is the loop. Each tick it takes every sample each device
delivered since the previous tick (never waiting for a device), advances the
scene pipeline to the tick time, publishes a frame per device, and spends
the rest of the period answering control requests and sleeping to the next
absolute deadline. Anything a user or device can get wrong is logged and
counted; the loop keeps the last good state and carries on.

Every tick that runs publishes one frame per open device, and ticks are
numbered consecutively (docs/design/architecture.md's frame contract). But when no device
has a contact, input waiting, or anything new to say, the loop stops ticking
and sleeps until a producer wakes it (stiction.daemon.wake), running one
keep-alive tick every `keepalive` seconds meanwhile: the deadlines it sleeps
through are skipped like a late loop's, `t` jumps and `tick` does not. A
daemon left running beside an unused tablet costs next to nothing.

This module is the loop and the sockets; the rest is composed in: the
devices (device_set.DeviceSet: opening, hot-plug, closing), the scene and
its changes (scene_state.SceneState, applied only between ticks) and the
replies to queries (status). The Daemon's public methods are the stable
surface the op table (ops.Controlled), tools and tests use; most of them
hand over to those parts.
"""

from __future__ import annotations

import gc
import logging
import math
import queue
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zmq

from stiction import protocol
from stiction.daemon import status
from stiction.daemon.clock import (
    Clock,
    RealClock,
    Schedule,
    VirtualClock,
    set_ordinary,
    set_realtime,
    tighten_timer_slack,
)
from stiction.daemon.control import ControlServer
from stiction.daemon.device_set import DeviceSet, Opener
from stiction.daemon.devices import DeviceSlot, open_source, take_live, take_virtual
from stiction.daemon.ops import OpTable
from stiction.daemon.options import Options, validate
from stiction.daemon.prepare import Prepared, Preparer
from stiction.daemon.publisher import Publisher, Sink
from stiction.daemon.scene_state import SceneState
from stiction.daemon.security import Guard
from stiction.daemon.stats import Window
from stiction.daemon.wake import Waker
from stiction.daemon.warm import Warmer
from stiction.errors import StictionError
from stiction.scene.backend import SimulatorBackend
from stiction.scene.model import Scene
from stiction.scene.pipeline import Pipeline

log = logging.getLogger("stiction.daemon")

SWITCH_INTERVAL_S = 0.0002


class Daemon:
    def __init__(
        self,
        opts: Options,
        ctx: zmq.Context[Any] | None = None,
        opener: Opener = open_source,
        publisher: Sink | None = None,
    ) -> None:
        """`publisher`: where frames and scene messages go; default, a ZeroMQ
        PUB bound to opts.pub when the daemon opens."""
        self.opts = validate(opts)
        self.virtual = opts.clock == "virtual"
        self.waker = Waker()
        self.last_frames: dict[str, protocol.FrameWire] = {}
        self.device_set = DeviceSet(self.opts, opener, self.waker, self.last_frames)
        self.scene_state = SceneState(
            self.opts,
            self.device_set,
            self.waker,
            publish=lambda: self._publish_scene(),
            last_tick=lambda: self.last_tick,
            reload_keys=lambda: self.guard.reload_keys(),
        )
        self.clock: Clock = VirtualClock() if self.virtual else RealClock(opts.spin_ms / 1e3)
        self.realtime = 0
        """The SCHED_FIFO priority the loop runs at (0: ordinary)."""
        self._own_ctx = ctx is None
        self.ctx: zmq.Context[Any] = ctx if ctx is not None else zmq.Context()
        self.guard = Guard(self.ctx, opts.curve)
        self._given_publisher = publisher
        self.publisher: Sink | None = None
        self.control: ControlServer | None = None
        self.schedule = Schedule(opts.rate, 0.0, _ms(opts.late_threshold_ms))
        self.last_tick = -1
        self.last_tick_t = -math.inf
        """Deadline of the last tick run (the keep-alive counts from it)."""
        self.jitter = Window(opts.stats_window)
        self.latency = Window(opts.stats_window)
        self.cost = Window(opts.stats_window)
        self.cost_cpu = Window(opts.stats_window)
        """The loop thread's CPU time in each tick: the work without the preemptions."""
        self._stop = threading.Event()
        self._reload = threading.Event()
        self.started = time.monotonic()
        """When the daemon was made: the stats reply's uptime counts from it."""
        self.on_tick: Callable[[int], None] | None = None
        """Test hook: called after each published tick with its number."""
        self.warm_spin = True  # run the tick's paths on scratch state in the spin (warm.py)
        self.prepare_spin = True
        """Compute each live tick during the spin and send it as computed at the
        deadline if nothing changed in between (prepare.py)."""
        self.prepare_ahead = False
        """An experiment, off by default: prepare well before the spin (the
        clock's learnt lead) and nap to it, redoing the preparation when
        input arrives (clock.RealClock, `nap`). It made the late wake-ups
        harmless but the ticks sent as prepared dearer, and cost more CPU;
        the p99 of the tick's work was no better (docs/daemon.md, "Issue 15:
        preparing ahead")."""
        self.preparer: Preparer | None = None
        """The running loop's (None before run, under the virtual clock, or
        with prepare_spin off); the stats reply reads its counts."""

    # ------------------------------------------------------------ the parts' state
    # The loop, the op table and tests read these as the daemon's own; each
    # lives in the part that changes it.
    @property
    def slots(self) -> list[DeviceSlot]:
        return self.device_set.slots

    @property
    def hotplug(self) -> Any:
        """The hot-plug watcher (None without one); tests may put their own in."""
        return self.device_set.hotplug

    @hotplug.setter
    def hotplug(self, watcher: Any) -> None:
        self.device_set.hotplug = watcher

    @property
    def pipeline(self) -> Pipeline:
        return self.scene_state.pipeline

    @property
    def defaults(self) -> dict[str, Any]:
        return self.scene_state.defaults

    @property
    def backend(self) -> SimulatorBackend:
        return self.scene_state.backend

    @property
    def counters(self) -> dict[str, int]:
        return self.scene_state.counters

    @property
    def generation(self) -> int:
        """Counts pipeline swaps (a change prepared against an older pipeline is redone)."""
        return self.scene_state.generation

    @property
    def _tasks(self) -> queue.SimpleQueue[Callable[[], None]]:
        return self.scene_state.tasks

    # ------------------------------------------------------------ set-up
    def open(self) -> None:
        """Bind sockets and open devices; errors here are the user's to fix.

        On any error everything opened so far is closed again: a context left
        with open sockets would block forever when garbage-collected."""
        try:
            self._open()
        except BaseException:
            self.close()
            raise

    def _open(self) -> None:
        self.publisher = self._given_publisher or Publisher(
            self.ctx, self.opts.pub, self.guard, self.opts.hwm
        )
        self.control = ControlServer(
            self.ctx, self.opts.control, self.guard, OpTable(self), on_request=self.waker.wake
        )
        self.device_set.open(self.pipeline.scene.display, self.realtime)
        if self.virtual:
            self._align_virtual()
        log.info(
            "started pub=%s control=%s rate=%s clock=%s scene=%s devices=%s",
            self.publisher.endpoint,
            self.control.endpoint,
            self.opts.rate,
            self.opts.clock,
            self.pipeline.scene.source,
            ",".join(s.name for s in self.slots),
        )

    def _align_virtual(self) -> None:
        """Virtual time starts at the first device's recorded time."""
        start = self.device_set.align_virtual()
        self.clock = VirtualClock(start)
        self.schedule = Schedule(self.opts.rate, start, _ms(self.opts.late_threshold_ms))

    def _reader_realtime(self, slot: DeviceSlot) -> None:
        self.device_set.reader_realtime(slot, self.realtime)

    def _adopt(self) -> None:
        """Install devices the hot-plug watcher reopened (loop thread only)."""
        self.device_set.adopt(self.pipeline.scene.display, self.realtime)

    def close(self) -> None:
        self.device_set.close()
        if self.control is not None:
            self.control.close()
            self.control = None
        if self.publisher is not None:
            self.publisher.close()
            self.publisher = None
        self.guard.close()
        if self._own_ctx:
            self.ctx.term()

    # ------------------------------------------------------------ control flags
    def request_stop(self) -> None:
        self._stop.set()
        self.scene_state.stop()  # lets the reload thread see the stop
        self.waker.wake()

    def request_reload(self) -> None:
        self._reload.set()
        self.waker.wake()

    # ------------------------------------------------------------ the loop
    def run(self) -> int:
        assert self.publisher is not None
        # Reader threads decode reports in Python; with the default 5 ms GIL
        # switch interval a tick whose sleep ended could wait that long for the
        # interpreter. A short interval bounds that wait.
        switch = sys.getswitchinterval()
        sys.setswitchinterval(min(switch, SWITCH_INTERVAL_S))
        if not self.virtual:
            tighten_timer_slack()
            if self.opts.realtime:
                refused = set_realtime(self.opts.realtime)
                if refused:
                    prio = self.opts.realtime
                    log.warning("realtime_refused priority=%d reason=%s", prio, refused)
                else:
                    self.realtime = self.opts.realtime
                    log.info("realtime priority=%d readers=%d", self.realtime,
                             max(self.realtime - 1, 1))  # fmt: skip
                    for slot in self.slots:
                        if slot.thread is not None and slot.thread.is_alive():
                            self._reader_realtime(slot)
        self.pipeline.warm_up()  # compile (or load) the batch step before the clock starts
        # Everything built so far (modules, scene, compiled kernels) lives as
        # long as the daemon: out of the collector's way, so that a full
        # collection during a tick walks only what the ticks allocate.
        gc.collect()
        gc.freeze()
        try:
            return self._run()
        finally:
            sys.setswitchinterval(switch)
            gc.unfreeze()
            if self.realtime:
                set_ordinary()  # the thread may be the caller's; stats still say how it ran

    def _run(self) -> int:
        assert self.publisher is not None
        if self.virtual and self.opts.wait_subscribers:
            want = self.opts.wait_subscribers
            got = self.publisher.wait_subscribers(want, self.opts.wait_timeout)
            if got < want:
                log.warning("wait_subscribers got=%d of %d after %g s: starting anyway", got,
                            want, self.opts.wait_timeout)  # fmt: skip
            else:
                log.info("subscribers=%d ready", got)
        self._publish_scene()
        if not self.virtual:
            start = self.opts.start if self.opts.start is not None else self.clock.now() + 0.01
            self.schedule = Schedule(self.opts.rate, start, _ms(self.opts.late_threshold_ms))
        limit = None if self.opts.seconds is None else round(self.opts.seconds * self.opts.rate)
        prev_t = -math.inf
        warmer = Warmer(self, 1.0 / self.opts.rate) if self.warm_spin else None
        # A virtual tick takes its samples from a finite source (take_virtual):
        # there is no spin and nothing to prepare.
        if self.prepare_spin and not self.virtual:
            self.preparer = Preparer(self, warmer)
        spin = (
            self.preparer.prepare
            if self.preparer is not None
            else warmer.warm
            if warmer is not None
            else None
        )
        watch = self.preparer.watch if self.preparer is not None else None
        nap = self.preparer.nap if self.preparer is not None and self.prepare_ahead else None
        while not self._stop.is_set():
            if limit is not None and self.schedule.index >= limit:
                break
            if self.control is not None:
                self.control.serve_pending()
            self._run_tasks()
            if self._may_idle() and self._idle(limit):
                continue
            deadline = self.schedule.deadline
            self.clock.sleep_until(deadline, spin, watch, nap)
            woke = self.clock.now()
            cpu = time.thread_time()
            lateness = self.schedule.begin(woke)
            # A preparation that ran past the deadline (clock.RealClock.overrun):
            # the tick's own work, which the statistics count as such.
            overrun = getattr(self.clock, "overrun", 0.0)
            if self._reload.is_set():
                self._reload.clear()
                self._start_reload()
            hotplug = self.device_set.hotplug
            if hotplug is not None and not hotplug.ready.empty():
                self._adopt()
            self._tick(deadline, prev_t)
            prev_t = deadline
            done = self.clock.now()
            if not self.virtual:
                self.jitter.add(lateness - overrun)
                self.cost.add(done - woke + overrun)
                over_cpu = getattr(self.clock, "overrun_cpu", 0.0)
                self.cost_cpu.add(time.thread_time() - cpu + over_cpu)
            self.schedule.finish(done)
            if self.on_tick is not None:
                self.on_tick(self.last_tick)
            if self.virtual and all(s.run is None for s in self.slots):
                break
        log.info(
            "stopped ticks=%d late=%d skipped=%d",
            self.schedule.ticks,
            self.schedule.late,
            self.schedule.skipped,
        )
        return 0

    def _may_idle(self) -> bool:
        """Nothing to simulate and nothing new to publish until a producer wakes us."""
        if self.virtual or self.opts.keepalive == 0:
            return False
        for slot in self.slots:
            if slot.run is None:
                continue
            if not slot.quiet or slot.run.tracks or slot.queue or slot.pending or slot.went_away:
                return False
        return True

    def _idle(self, limit: int | None) -> bool:
        """Sleep until there is work or a keep-alive frame is due, then rejoin the
        grid. False if there was no reason to sleep: the next deadline ticks."""
        waker = self.waker
        waited = False
        waker.arm()
        try:
            busy = (
                self._stop.is_set()
                or self._reload.is_set()
                or not self._tasks.empty()
                or not self._may_idle()
                or (self.control is not None and self.control.has_pending())
                or (self.hotplug is not None and not self.hotplug.ready.empty())
            )
            if not busy:
                running = any(s.run is not None for s in self.slots)
                due = self.last_tick_t + self.opts.keepalive if running else math.inf
                if limit is not None:
                    due = min(due, self.schedule.start + limit / self.schedule.rate)
                # Wake a tick before the keep-alive is due, to publish it on time.
                timeout = due - self.clock.now() - 1.0 / self.schedule.rate
                if timeout > 0:
                    waker.wait(timeout)
                    waited = True
        finally:
            waker.disarm()
        self.schedule.resume(self.clock.now())
        return waited

    def _tick(self, t: float, prev_t: float) -> None:
        pub = self.publisher
        assert pub is not None
        tick = self.schedule.ticks
        preparer = self.preparer
        for slot in self.slots:
            run = slot.run
            if run is None:
                continue
            if preparer is not None:
                p = preparer.claim(slot, tick, t, prev_t)
                if p is not None:
                    self._send_prepared(slot, p, tick, t)
                    continue
            newest: float | None = None
            if self.virtual:
                samples = take_virtual(slot, t)
                finished = slot.iterator is None
            else:
                samples, newest = take_live(slot, prev_t, t)
                finished = slot.went_away and not slot.queue and not slot.pending
            if samples:
                slot.meter.add(len(samples), t)
            try:
                contacts = self.pipeline.step(run, t, prev_t, samples)
            except Exception as exc:
                # Nothing a device sends may stop the loop: end this device's
                # contacts, count it, and carry on with a clean state.
                slot.errors += 1
                if isinstance(exc, StictionError):
                    log.warning("step_failed device=%s error=%s", slot.name, exc)
                else:
                    log.exception("step_crashed device=%s", slot.name)
                try:
                    contacts = self.pipeline.end_all(run)
                except Exception:
                    run.tracks.clear()
                    contacts = []
            if finished:
                # The device is gone: every contact still live ends here, once, as "up".
                ended = self.pipeline.end_all(run)
                ids = {c["id"] for c in ended}
                self._keep_last_material(slot.name, contacts, ended)
                contacts = [c for c in contacts if c["id"] not in ids] + ended
                contacts.sort(key=lambda c: c["id"])
            last = self.last_frames.get(slot.name)
            # No input and no contact, after a frame that had no contact either
            # (so the state after a lift-off is published once): if every
            # device is quiet, the loop may idle.
            slot.quiet = (
                not samples
                and not finished
                and not contacts
                and last is not None
                and not last["contacts"]
            )
            t_input = slot.last_t if math.isfinite(slot.last_t) else None
            frame = protocol.frame(tick, slot.sent_tick, t, t_input, slot.name, contacts)
            pub.send(protocol.frame_topic(slot.name), frame)
            self.last_frames[slot.name] = frame
            slot.sent_tick = tick
            if newest is not None:
                self.latency.add(time.monotonic() - newest)
            if finished:
                slot.run = None
                if slot.state == "open":
                    slot.state = "ended" if slot.spec.finite else "absent"
                if slot.source is not None:
                    slot.source.close()
                log.info("device_stopped device=%s state=%s", slot.name, slot.state)
        self.last_tick = tick
        self.last_tick_t = t

    def _send_prepared(self, slot: DeviceSlot, p: Prepared, tick: int, t: float) -> None:
        """The tick for `slot` as prepared before the deadline (prepare.py):
        what the ordinary tick below does for a device that is not finished."""
        pub: Any = self.publisher
        if p.payload is not None:
            pub.send_payload(p.topic, p.payload)  # first: the rest is bookkeeping
        else:
            pub.send(p.topic, p.frame)
        p.commit(slot)
        taken = p.taken
        if taken.samples:
            slot.meter.add(len(taken.samples), t)
        slot.quiet = p.quiet
        self.last_frames[slot.name] = p.frame
        slot.sent_tick = tick
        if taken.newest is not None:
            self.latency.add(time.monotonic() - taken.newest)

    def _keep_last_material(self, name: str, current: list[Any], ended: list[Any]) -> None:
        """Give each closing "up" the material (and string) its contact last had.

        The pipeline's end_all cannot know where the contact was last seen
        (it reports "pass-through"), but a client must see a closing "up" like
        any other: on the material the contact was on, with a string of length
        0 when the scene has the string effect. The newest report is this
        tick's step, else the last published frame.
        """
        last = self.last_frames.get(name)
        seen: dict[int, Any] = {c["id"]: c for c in (last["contacts"] if last else [])}
        seen.update({c["id"]: c for c in current})
        for c in ended:
            before = seen.get(c["id"])
            if before is not None:
                c["material"] = before["material"]
            if self.pipeline.string and "string" not in c:
                c["string"] = {"length_px": 0.0, "dir": [0.0, 0.0]}

    # ------------------------------------------------------------ scene and params
    def _publish_scene(self) -> None:
        assert self.publisher is not None
        msg = protocol.scene_message(self.pipeline.wire(), self.last_tick)
        self.publisher.send(protocol.TOPIC_SCENE, msg)

    # ------------------------------------------------------------ changes (scene_state.py)
    def prepare_scene(
        self, scene: Scene, defaults: dict[str, Any] | None = None, *, count: bool = True
    ) -> Pipeline:
        return self.scene_state.prepare_scene(scene, defaults, count=count)

    def apply_pipeline(self, pipeline: Pipeline, defaults: dict[str, Any] | None = None) -> None:
        self.scene_state.apply_pipeline(pipeline, defaults)

    def set_scene(self, scene: Scene) -> None:
        self.scene_state.set_scene(scene)

    def load_scene_text(self, text: str, source: str) -> Scene:
        return self.scene_state.load_scene_text(text, source)

    def load_scene_file(self, path: Path) -> Scene:
        return self.scene_state.load_scene_file(path)

    def prepare_params(
        self, values: dict[str, Any], material: str | None
    ) -> tuple[Pipeline, dict[str, Any]]:
        return self.scene_state.prepare_params(values, material)

    def set_params(self, values: dict[str, Any], material: str | None) -> None:
        self.scene_state.set_params(values, material)

    def log_params(self, values: dict[str, Any], material: str | None) -> None:
        self.scene_state.log_params(values, material)

    def reload(self) -> None:
        self.scene_state.reload()

    def post(self, task: Callable[[], None]) -> None:
        self.scene_state.post(task)

    def _run_tasks(self) -> None:
        self.scene_state.run_tasks()

    def _start_reload(self) -> None:
        self.scene_state.start_reload()

    # ------------------------------------------------------------ replies (status.py)
    def stats(self) -> protocol.StatsWire:
        return status.stats(self)

    def devices(self) -> list[protocol.DeviceWire]:
        return status.devices(self)

    def scene_wire(self) -> protocol.SceneWire:
        return self.pipeline.wire()

    def scene_text(self) -> str:
        return self.pipeline.scene.text

    def params_reply(self) -> protocol.ParamsReply:
        return status.params(self)

    def ping(self) -> protocol.PingReply:
        return status.ping(self)

    def snapshot(self) -> protocol.SnapshotReply:
        return status.snapshot(self)


def _ms(value: float | None) -> float | None:
    return None if value is None else value / 1e3
