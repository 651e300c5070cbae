"""The daemon's devices: which ones, opening them, taking them in, closing them.

A `DeviceSet` owns the device slots of one daemon. It opens the configured
devices (or, with none named, every usable tablet and touchpad found, else
the synthetic pen), installs an opened source into its slot (mapping,
contact state, reader thread), starts the hot-plug watcher, adopts what the
watcher reopened, and closes everything again. It knows nothing of the
loop's schedule or the scene: the caller passes the display the mapping
targets and the loop's real-time priority with each call that needs them,
so the loop (daemon/service.py) stays the one owner of both.

Only the loop thread calls `install`, `adopt` and `remap`, at a tick
boundary: the slots' per-device state is never touched by two threads.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from stiction import protocol
from stiction.daemon.clock import set_thread_realtime
from stiction.daemon.devices import (
    ClockMap,
    DeviceConfig,
    DeviceSlot,
    Spec,
    parse_spec,
    start_reader,
)
from stiction.daemon.mapping import MappingConfig, make_mapping
from stiction.daemon.options import Options
from stiction.daemon.wake import Waker
from stiction.drivers.info import DeviceInfo
from stiction.drivers.source import SampleSource
from stiction.errors import DeviceError, StictionError
from stiction.scene.pipeline import DeviceRun
from stiction.userfiles import shown

log = logging.getLogger("stiction.daemon")  # the loop's logger: log lines keep their name

Opener = Callable[[Spec, DeviceConfig, bool, bool], SampleSource]
"""open_source's signature: spec, its config, realtime, loop."""

Display = tuple[int, int]
"""The scene's display size in pixels, which a device's mapping targets."""


class DeviceSet:
    """The slots of one daemon and everything that adds, reopens or closes one."""

    def __init__(
        self,
        opts: Options,
        opener: Opener,
        waker: Waker,
        last_frames: dict[str, protocol.FrameWire],
    ) -> None:
        """`last_frames`: the loop's last published frame per device; a device
        (re)opened is dropped from it so that its state is announced at once."""
        self.opts = opts
        self.opener = opener
        self.virtual = opts.clock == "virtual"
        self.waker = waker
        self.last_frames = last_frames
        self.slots: list[DeviceSlot] = []
        self.hotplug: Any = None
        """The hot-plug watcher (daemon/hotplug.py), once started; None without one."""

    def open(self, display: Display, realtime: int) -> None:
        """Open every configured device; with a live clock, start the hot-plug watcher."""
        configs = self.opts.devices or auto_devices()
        for cfg in configs:
            spec = parse_spec(cfg.spec)
            if self.virtual and not spec.finite:
                raise StictionError(
                    f"--clock virtual needs replay: or synthetic: devices, not {cfg.spec!r}"
                )
            slot = DeviceSlot(config=cfg, spec=spec, name=cfg.spec)
            self.slots.append(slot)
            try:
                source = self.opener(spec, cfg, not self.virtual, not self.virtual)
                self.install(slot, source, display, realtime)
            except Exception as exc:
                # A real device that cannot be opened now is watched for; a
                # replay or synthetic stroke that cannot be opened is the user's error.
                if spec.finite:
                    raise
                log.warning(
                    "device_absent spec=%s error=%s (waiting for it to appear)", cfg.spec, exc
                )
            slot.name = self.nth_name(slot)
        if self.virtual or not self.opts.hotplug:
            return
        if not self.opts.devices or any(not s.spec.finite for s in self.slots):
            self._watch()

    def _watch(self) -> None:
        from stiction.daemon.hotplug import Hotplug

        opener = self.opener
        self.hotplug = Hotplug(
            lambda: self.slots,
            lambda s: opener(s.spec, s.config, True, True),
            discover=None if self.opts.devices else discover_specs,
            on_ready=self.waker.wake,
        )
        self.hotplug.start()

    def install(self, slot: DeviceSlot, source: Any, display: Display, realtime: int) -> None:
        """Make an opened source the slot's device: mapping, contact state, reader."""
        kind = getattr(source, "kind", "pen")
        self._check_same_device(slot, source)
        size = slot.config.surface_size or source.surface_size
        slot.kind = kind
        cfg = mapping_config(slot)
        try:
            mapping = make_mapping(size, display, cfg, source.name)
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
            if realtime:  # a device opened (or reopened) while the loop is real-time
                self.reader_realtime(slot, realtime)

    @staticmethod
    def _check_same_device(slot: DeviceSlot, source: Any) -> None:
        """A node reopened at a configured path may be another device: the kernel
        gives event and hidraw numbers to whatever is plugged in next. A size
        configured for the first device would then be a silent wrong surface on
        this one, so that reopening is refused; without one, the newcomer is
        read on its own size and the change is logged."""
        if slot.source is None:  # the first opening: nothing to compare with
            return
        before = slot.source.name  # the device last opened here (closed, its name kept)
        if source.name == before:
            return
        if slot.config.surface_size is not None:
            source.close()
            raise DeviceError(
                f"{shown(slot.config.spec)} is now {shown(repr(source.name))}, not {before!r}: "
                f"the size configured for {before!r} is not applied to another device; "
                "name it by a path that follows it (/dev/input/by-id/..., or VID:PID)"
            )
        log.info(
            "device_changed device=%s spec=%s was=%r now=%r",
            slot.name, slot.config.spec, before, source.name,
        )  # fmt: skip

    def reader_realtime(self, slot: DeviceSlot, realtime: int) -> None:
        """The reader one priority below the loop's (clock.set_thread_realtime says why)."""
        thread = slot.thread
        if thread is None or thread.native_id is None:
            return
        prio = max(realtime - 1, 1)
        refused = set_thread_realtime(thread.native_id, prio)
        if refused:
            log.warning("reader_realtime_refused device=%s reason=%s", slot.name, refused)

    def align_virtual(self) -> float:
        """Virtual time is the first device's recorded time; others start with it.

        Returns that start time (0.0 with no sample at all) for the loop's clock."""
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
        return t0 if t0 is not None else 0.0

    def adopt(self, display: Display, realtime: int) -> None:
        """Install devices the hot-plug watcher reopened (loop thread only)."""
        hp = self.hotplug
        if hp is None:
            return
        while not hp.ready.empty():
            slot, source = hp.ready.get_nowait()
            try:
                new = slot not in self.slots
                self.install(slot, source, display, realtime)
                if new:
                    slot.name = self.nth_name(slot)
                    self.slots.append(slot)
                    log.info("device_added device=%s spec=%s", slot.name, slot.config.spec)
                else:
                    slot.reopened += 1
                    log.info("device_reopened device=%s", slot.name)
            except StictionError as exc:
                log.warning("reopen_refused device=%s error=%s", slot.name, exc)
            hp.installed(slot)

    def remap(self, display: Display) -> None:
        """Map every running device onto a new display size (a scene with another display)."""
        for slot in self.slots:
            if slot.run is not None:
                cfg = mapping_config(slot)
                slot.run.mapping = make_mapping(slot.surface_size, display, cfg, slot.name)

    def close(self) -> None:
        """Stop the watcher, close every source and wait for the readers to end."""
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

    def nth_name(self, slot: DeviceSlot) -> str:
        """The n-th device of one name is `name#n` (A, B, A: A, B, A#2), as protocol.md says."""
        base = slot.name

        def same(name: str) -> bool:
            tail = name[len(base) + 1 :]
            return name == base or (name.startswith(base + "#") and tail.isdigit())

        n = sum(1 for s in self.slots if s is not slot and same(s.name))
        return base if n == 0 else f"{base}#{n + 1}"


def mapping_config(slot: DeviceSlot) -> MappingConfig:
    """Touchpads default to relative mapping, everything else to area mapping."""
    if not slot.config.mapping_given and slot.kind == "touchpad":
        return MappingConfig(mode="relative")
    return slot.config.mapping


def discover_nodes() -> list[DeviceInfo]:
    """The usable tablets, touchpads and touchscreens present now, one node each.

    A tablet shows up both as hidraw and as evdev nodes; discovery picks the
    one to read it through (stiction.drivers.discovery has the rule)."""
    from stiction.drivers.discovery import discover_all

    return [i for i in discover_all() if i.chosen and i.problem is None]


def discover_specs() -> list[str]:
    """Paths of the usable tablets, touchpads and touchscreens present now."""
    return [i.path for i in discover_nodes()]


def auto_devices() -> list[DeviceConfig]:
    """No devices named: every usable tablet/touchpad found, else the synthetic pen
    (tablets plugged in later are picked up by the hot-plug watcher)."""
    try:
        nodes = discover_nodes()
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
