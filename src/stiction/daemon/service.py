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
from typing import Any, cast

import zmq

from stiction import __version__, protocol
from stiction.daemon.clock import (
    Clock,
    RealClock,
    Schedule,
    VirtualClock,
    set_ordinary,
    set_realtime,
    set_thread_realtime,
    tighten_timer_slack,
)
from stiction.daemon.config import load_options
from stiction.daemon.control import ControlServer
from stiction.daemon.devices import (
    ClockMap,
    DeviceConfig,
    DeviceSlot,
    Spec,
    open_source,
    parse_spec,
    start_reader,
    take_live,
    take_virtual,
)
from stiction.daemon.mapping import MappingConfig, make_mapping
from stiction.daemon.ops import OpTable
from stiction.daemon.options import Options, validate
from stiction.daemon.publisher import Publisher, Sink
from stiction.daemon.security import Guard
from stiction.daemon.stats import Window
from stiction.daemon.wake import Waker
from stiction.daemon.warm import Warmer
from stiction.drivers.info import DeviceInfo
from stiction.drivers.source import SampleSource
from stiction.errors import StictionError
from stiction.scene.backend import SimulatorBackend
from stiction.scene.load import default_scene, load_scene, parse_scene
from stiction.scene.model import Scene
from stiction.scene.pipeline import DeviceRun, Pipeline

log = logging.getLogger("stiction.daemon")

SWITCH_INTERVAL_S = 0.0002

Opener = Callable[[Spec, DeviceConfig, bool, bool], SampleSource]
"""open_source's signature: spec, its config, realtime, loop."""


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
        self.opener = opener
        self.virtual = opts.clock == "virtual"
        self.backend = SimulatorBackend(opts.integrator, opts.substeps)
        self.defaults = {**self.backend.defaults(), **opts.params, "rate": opts.rate}
        scene = load_scene(opts.scene) if opts.scene else default_scene(opts.display)
        self.pipeline = Pipeline(scene, self.backend, self.defaults)
        self.clock: Clock = VirtualClock() if self.virtual else RealClock(opts.spin_ms / 1e3)
        self.realtime = 0
        """The SCHED_FIFO priority the loop runs at (0: ordinary)."""
        self.waker = Waker()
        self._own_ctx = ctx is None
        self.ctx: zmq.Context[Any] = ctx if ctx is not None else zmq.Context()
        self.guard = Guard(self.ctx, opts.curve)
        self._given_publisher = publisher
        self.publisher: Sink | None = None
        self.control: ControlServer | None = None
        self.slots: list[DeviceSlot] = []
        self.schedule = Schedule(opts.rate, 0.0, _ms(opts.late_threshold_ms))
        self.last_tick = -1
        self.last_tick_t = -math.inf
        """Deadline of the last tick run (the keep-alive counts from it)."""
        self.last_frames: dict[str, protocol.FrameWire] = {}
        self.jitter = Window(opts.stats_window)
        self.latency = Window(opts.stats_window)
        self.cost = Window(opts.stats_window)
        self.counters = {"scene_loads": 1, "scene_errors": 0, "reloads": 0}
        self.generation = 0
        """Counts pipeline swaps (a change prepared against an older pipeline is redone)."""
        self._stop = threading.Event()
        self._reload = threading.Event()
        self._reload_worker: threading.Thread | None = None
        self._reload_wanted = threading.Event()
        self._tasks: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._started = time.monotonic()
        self.hotplug: Any = None
        self.on_tick: Callable[[int], None] | None = None
        """Test hook: called after each published tick with its number."""
        self.warm_spin = True  # run the tick's paths on scratch state in the spin (warm.py)

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
        configs = self.opts.devices or _auto_devices()
        for cfg in configs:
            spec = parse_spec(cfg.spec)
            if self.virtual and not spec.finite:
                raise StictionError(
                    f"--clock virtual needs replay: or synthetic: devices, not {cfg.spec!r}"
                )
            slot = DeviceSlot(config=cfg, spec=spec, name=cfg.spec)
            self.slots.append(slot)
            try:
                self._install(slot, self.opener(spec, cfg, not self.virtual, not self.virtual))
            except Exception as exc:
                # A real device that cannot be opened now is watched for; a
                # replay or synthetic stroke that cannot be opened is the user's error.
                if spec.finite:
                    raise
                log.warning(
                    "device_absent spec=%s error=%s (waiting for it to appear)", cfg.spec, exc
                )
            slot.name = self._nth_name(slot)
        if self.virtual:
            self._align_virtual()
        elif self.opts.hotplug and (
            not self.opts.devices or any(not s.spec.finite for s in self.slots)
        ):
            from stiction.daemon.hotplug import Hotplug

            opener = self.opener
            self.hotplug = Hotplug(
                lambda: self.slots,
                lambda s: opener(s.spec, s.config, True, True),
                discover=None if self.opts.devices else _discover_specs,
                on_ready=self.waker.wake,
            )
            self.hotplug.start()
        log.info(
            "started pub=%s control=%s rate=%s clock=%s scene=%s devices=%s",
            self.publisher.endpoint,
            self.control.endpoint,
            self.opts.rate,
            self.opts.clock,
            self.pipeline.scene.source,
            ",".join(s.name for s in self.slots),
        )

    def _install(self, slot: DeviceSlot, source: Any) -> None:
        """Make an opened source the slot's device: mapping, contact state, reader."""
        kind = getattr(source, "kind", "pen")
        size = slot.config.surface_size or source.surface_size
        slot.kind = kind
        cfg = self._mapping_config(slot)
        try:
            mapping = make_mapping(size, self.pipeline.scene.display, cfg, source.name)
        except StictionError:
            source.close()
            raise
        if slot.source is None and slot.name == slot.config.spec:
            slot.name = source.name
        slot.source = source
        slot.kind = kind
        slot.surface_size = size
        slot.run = DeviceRun(mapping)
        slot.clock = ClockMap()  # a reopened device's clock is learnt afresh
        slot.state = "open"
        slot.opened = True
        slot.went_away = False
        slot.quiet = False
        self.last_frames.pop(slot.name, None)  # announce the (re)opened device at once
        if self.virtual:
            slot.iterator = iter(source.samples())
        else:
            start_reader(slot, lambda s: None, self.waker)
            if self.realtime:  # a device opened (or reopened) while the loop is real-time
                self._reader_realtime(slot)

    def _reader_realtime(self, slot: DeviceSlot) -> None:
        """The reader one priority below the loop (clock.set_thread_realtime says why)."""
        thread = slot.thread
        if thread is None or thread.native_id is None:
            return
        prio = max(self.realtime - 1, 1)
        refused = set_thread_realtime(thread.native_id, prio)
        if refused:
            log.warning("reader_realtime_refused device=%s reason=%s", slot.name, refused)

    @staticmethod
    def _mapping_config(slot: DeviceSlot) -> MappingConfig:
        """Touchpads default to relative mapping, everything else to area mapping."""
        if not slot.config.mapping_given and slot.kind == "touchpad":
            return MappingConfig(mode="relative")
        return slot.config.mapping

    def _align_virtual(self) -> None:
        """Virtual time is the first device's recorded time; others start with it."""
        t0: float | None = None
        for slot in self.slots:
            if slot.iterator is None:
                continue
            try:
                first = next(slot.iterator)
            except StopIteration:
                slot.iterator = None
                slot.state = "ended"
                continue
            slot.lookahead = first
            if t0 is None:
                t0 = first.t
            slot.clock.offset = t0 - first.t
        start = t0 if t0 is not None else 0.0
        self.clock = VirtualClock(start)
        self.schedule = Schedule(self.opts.rate, start, _ms(self.opts.late_threshold_ms))

    def _adopt(self) -> None:
        """Install devices the hot-plug watcher reopened (loop thread only)."""
        hp = self.hotplug
        if hp is None:
            return
        while not hp.ready.empty():
            slot, source = hp.ready.get_nowait()
            try:
                new = slot not in self.slots
                self._install(slot, source)
                if new:
                    slot.name = self._nth_name(slot)
                    self.slots.append(slot)
                    log.info("device_added device=%s spec=%s", slot.name, slot.config.spec)
                else:
                    slot.reopened += 1
                    log.info("device_reopened device=%s", slot.name)
            except StictionError as exc:
                log.warning("reopen_refused device=%s error=%s", slot.name, exc)
            hp.installed(slot)

    def close(self) -> None:
        if self.hotplug is not None:
            self.hotplug.stop()
        for slot in self.slots:
            if slot.source is not None:
                try:
                    slot.source.close()
                except Exception:
                    log.exception("device_close_failed device=%s", slot.name)
        for slot in self.slots:
            if slot.thread is not None:
                slot.thread.join(timeout=1.0)
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
        self._reload_wanted.set()  # lets the reload thread see the stop
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
        warm = Warmer(self, 1.0 / self.opts.rate).warm if self.warm_spin else None
        while not self._stop.is_set():
            if limit is not None and self.schedule.index >= limit:
                break
            if self.control is not None:
                self.control.serve_pending()
            self._run_tasks()
            if self._may_idle() and self._idle(limit):
                continue
            deadline = self.schedule.deadline
            self.clock.sleep_until(deadline, warm)
            woke = self.clock.now()
            lateness = self.schedule.begin(woke)
            if not self.virtual:
                self.jitter.add(lateness)
            if self._reload.is_set():
                self._reload.clear()
                self._start_reload()
            self._adopt()
            self._tick(deadline, prev_t)
            prev_t = deadline
            done = self.clock.now()
            if not self.virtual:
                self.cost.add(done - woke)
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
        for slot in self.slots:
            run = slot.run
            if run is None:
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

    def prepare_scene(
        self, scene: Scene, defaults: dict[str, Any] | None = None, *, count: bool = True
    ) -> Pipeline:
        """Compile `scene` and check that what it will publish can be encoded; apply nothing.

        Safe off the loop thread: it reads the current pipeline only for the tick
        number. A refused scene is counted and leaves the running one untouched.
        """
        try:
            pipeline = Pipeline(
                scene, self.backend, self.defaults if defaults is None else defaults
            )
            wire = pipeline.wire()
            protocol.encode(protocol.scene_message(wire, max(self.last_tick, 0)))
            protocol.encode(protocol.scene_reply(wire, scene.text))
        except StictionError:
            if count:
                self.counters["scene_errors"] += 1
            raise
        return pipeline

    def apply_pipeline(self, pipeline: Pipeline, defaults: dict[str, Any] | None = None) -> None:
        """Switch to a prepared pipeline (loop thread): nothing here can fail on user input."""
        old_display = self.pipeline.scene.display
        scene = pipeline.scene
        self.pipeline = pipeline
        if defaults is not None:
            self.defaults = defaults
        self.counters["scene_loads"] += 1
        self.generation += 1
        if scene.display != old_display:
            for slot in self.slots:
                if slot.run is not None:
                    cfg = self._mapping_config(slot)
                    slot.run.mapping = make_mapping(
                        slot.surface_size, scene.display, cfg, slot.name
                    )
        log.info("scene_loaded name=%s source=%s", scene.name, scene.source)
        self._publish_scene()

    def set_scene(self, scene: Scene) -> None:
        """Compile and switch to `scene`; on any error the current scene stays."""
        self.apply_pipeline(self.prepare_scene(scene))

    def load_scene_text(self, text: str, source: str) -> Scene:
        try:
            return parse_scene(text, source)
        except StictionError:
            self.counters["scene_errors"] += 1
            raise

    def load_scene_file(self, path: Path) -> Scene:
        try:
            return load_scene(path)
        except StictionError:
            self.counters["scene_errors"] += 1
            raise

    def prepare_params(
        self, values: dict[str, Any], material: str | None
    ) -> tuple[Pipeline, dict[str, Any]]:
        """The pipeline and defaults with `values` applied, checked; refused as a whole."""
        from stiction.daemon.params import apply_params

        scene, defaults = apply_params(self.pipeline.scene, self.defaults, values, material)
        return self.prepare_scene(scene, defaults, count=False), defaults

    def set_params(self, values: dict[str, Any], material: str | None) -> None:
        """Change material parameters; refused as a whole if any value is invalid."""
        self.apply_pipeline(*self.prepare_params(values, material))
        self.log_params(values, material)

    def log_params(self, values: dict[str, Any], material: str | None) -> None:
        log.info("params_set material=%s values=%s", material, values)

    def reload(self) -> None:
        """SIGHUP: re-read the config's run-time settings and the scene; keep them on error.

        Runs on the caller's thread (a reload worker, not the loop): files are
        read and the scene compiled here, and only the swap is posted to the loop.
        """
        # `reloads` counts finished reloads (refused or applied), so a client
        # that sees it move also sees the outcome.
        opts = self.opts
        params = opts.params
        scene_path = opts.scene
        if opts.config_path is not None:
            try:
                new = load_options(opts.config_path)
            except StictionError as exc:
                log.error("reload_failed config=%s error=%s", opts.config_path, exc)
                self.counters["reloads"] += 1
                return
            if new.scene is not None and not opts.scene_from_flag:
                scene_path = new.scene
            params = new.params
        try:
            scene = (
                self.load_scene_file(scene_path)
                if scene_path
                else default_scene(self.pipeline.scene.display)
            )
            defaults = {**self.backend.defaults(), **params, "rate": opts.rate}
            pipeline = self.prepare_scene(scene, defaults)
        except StictionError as exc:
            log.error(
                "reload_failed scene=%s error=%s (keeping the current scene)", scene_path, exc
            )
            self.counters["reloads"] += 1
            return

        def swap() -> None:
            opts.scene, opts.params = scene_path, params
            if opts.config_path is not None:
                self.guard.reload_keys()
            self.apply_pipeline(pipeline, defaults)
            self.counters["reloads"] += 1

        self.post(swap)

    def post(self, task: Callable[[], None]) -> None:
        """Run `task` on the loop thread at the next tick boundary."""
        self._tasks.put(task)
        self.waker.wake()

    def _run_tasks(self) -> None:
        while not self._tasks.empty():
            task = self._tasks.get_nowait()
            try:
                task()
            except Exception:  # a bug in one task must not stop the loop
                log.exception("task_failed")

    def _start_reload(self) -> None:
        """Read and compile off the loop thread, on one long-lived reload thread.

        One thread for every SIGHUP rather than a new one each: a storm of
        signals costs no thread churn. Requests that come while a reload runs
        are coalesced into one more.
        """
        self._reload_wanted.set()
        if self._reload_worker is None:

            def work() -> None:
                while not self._stop.is_set():
                    self._reload_wanted.wait()
                    self._reload_wanted.clear()
                    if self._stop.is_set():
                        return
                    try:
                        self.reload()
                    except Exception:
                        log.exception("reload_failed")

            self._reload_worker = threading.Thread(target=work, name="reload", daemon=True)
            self._reload_worker.start()

    def _nth_name(self, slot: DeviceSlot) -> str:
        """The n-th device of one name is `name#n` (A, B, A: A, B, A#2), as protocol.md says."""
        base = slot.name

        def same(name: str) -> bool:
            tail = name[len(base) + 1 :]
            return name == base or (name.startswith(base + "#") and tail.isdigit())

        n = sum(1 for s in self.slots if s is not slot and same(s.name))
        return base if n == 0 else f"{base}#{n + 1}"

    # ------------------------------------------------------------ replies
    def stats(self) -> protocol.StatsWire:
        pub = self.publisher
        devices: dict[str, protocol.DeviceStatsWire] = {}
        for slot in self.slots:
            device: protocol.DeviceStatsWire = {
                "state": _reported_state(slot),
                "spec": slot.config.spec,
                "samples": slot.samples,
                "rejected": slot.rejected,
                "errors": slot.errors,
                "reopened": slot.reopened,
                "clock_steps": slot.clock.steps,
                "driver": slot.driver_stats(),
            }
            # protocol.md: a statistic not measured yet is absent, not 0.0.
            if slot.meter.rate is not None:
                device["rate_hz"] = round(slot.meter.rate, 2)
            devices[slot.name] = device
        control = self.control
        return {
            "uptime_s": round(time.monotonic() - self._started, 3),
            "rate": self.opts.rate,
            "clock": self.opts.clock,
            "ticks": self.schedule.ticks,
            "late_ticks": self.schedule.late,
            "skipped_deadlines": self.schedule.skipped,
            "idle_deadlines": self.schedule.slept,
            "idle_wakes": self.waker.wakes,
            "realtime": self.realtime,
            "late_threshold_ms": self.schedule.late_threshold * 1e3,
            "jitter_ms": _summary(self.jitter),
            "latency_ms": _summary(self.latency),
            "tick_cost_ms": _summary(self.cost),
            "published": pub.sent if pub else 0,
            "publish_dropped": pub.dropped if pub else 0,
            "control_requests": control.requests if control else 0,
            "control_errors": control.errors if control else 0,
            "scene_loads": self.counters["scene_loads"],
            "scene_errors": self.counters["scene_errors"],
            "reloads": self.counters["reloads"],
            "devices": devices,
        }

    def devices(self) -> list[protocol.DeviceWire]:
        return [
            {
                "name": slot.name,
                "spec": slot.config.spec,
                "kind": slot.kind,
                "state": _reported_state(slot),
                "surface_m": list(slot.surface_size) if slot.surface_size else None,
                "mapping": self._mapping_config(slot).mode,
            }
            for slot in self.slots
        ]

    def scene_wire(self) -> protocol.SceneWire:
        return self.pipeline.wire()

    def scene_text(self) -> str:
        return self.pipeline.scene.text

    def params_reply(self) -> protocol.ParamsReply:
        materials = self.pipeline.wire()["materials"]
        return protocol.params_reply(self.defaults, self.backend.integrator, materials)

    def ping(self) -> protocol.PingReply:
        return protocol.ping_reply(self.last_tick, __version__, self.opts.rate, self.opts.keepalive)

    def snapshot(self) -> protocol.SnapshotReply:
        return protocol.snapshot_reply(
            self.last_tick, self.pipeline.wire(), self.last_frames, self.opts.keepalive
        )


def _discover_nodes() -> list[DeviceInfo]:
    """The usable tablets, touchpads and touchscreens present now, one node each.

    A tablet shows up both as hidraw and as evdev nodes; discovery picks the
    one to read it through (stiction.drivers.discovery has the rule)."""
    from stiction.drivers.discovery import discover_all

    return [i for i in discover_all() if i.chosen and i.problem is None]


def _discover_specs() -> list[str]:
    """Paths of the usable tablets, touchpads and touchscreens present now."""
    return [i.path for i in _discover_nodes()]


def _auto_devices() -> list[DeviceConfig]:
    """No devices named: every usable tablet/touchpad found, else the synthetic pen
    (tablets plugged in later are picked up by the hot-plug watcher)."""
    try:
        nodes = _discover_nodes()
        for i in nodes:
            log.info("device_found node=%s backend=%s reason=%s", i.path, i.backend, i.reason)
        found = [i.path for i in nodes]
    except Exception:  # discovery problems must not stop the no-argument start
        log.exception("discovery_failed")
        found = []
    if not found:
        log.info("no_devices_found using=synthetic:demo")
        return [DeviceConfig("synthetic:demo")]
    return [DeviceConfig(path) for path in found]


def _ms(value: float | None) -> float | None:
    return None if value is None else value / 1e3


def _reported_state(slot: DeviceSlot) -> protocol.DeviceState:
    """`waiting` for a device never opened yet (a typo is refused at start), else the state."""
    if slot.state == "absent" and not slot.opened:
        return "waiting"
    return cast(protocol.DeviceState, slot.state)


def _summary(window: Window) -> protocol.Summary:
    """A window's p50/p99/max in milliseconds, as the stats reply carries them."""
    return cast(protocol.Summary, window.summary(1e3))
