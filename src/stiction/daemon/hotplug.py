"""Reopen devices that went away, when they come back.

A watcher thread waits for udev "add" events on the hidraw and input
subsystems (pyudev) and, as a fallback where udev is not available, retries
every few seconds. Opening happens on this thread, never in the loop; an
opened source is handed to the loop through a queue and installed at a tick
boundary, so the loop's per-device state is only ever touched by the loop.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any

from stiction.daemon.devices import DeviceConfig, DeviceSlot, open_source, parse_spec
from stiction.drivers.source import SampleSource
from stiction.errors import StictionError

log = logging.getLogger("stiction.daemon.hotplug")

RETRY_S = 3.0


class Hotplug:
    def __init__(
        self,
        slots: Callable[[], list[DeviceSlot]],
        opener: Callable[[DeviceSlot], SampleSource] | None = None,
        use_udev: bool = True,
        discover: Callable[[], list[str]] | None = None,
        on_ready: Callable[[], None] = lambda: None,
    ) -> None:
        self._slots = slots
        self._open = opener or (lambda s: open_source(s.spec, s.config, True, True))
        self._discover = discover
        """With no devices named, new tablets are picked up: returns the specs present."""
        self.ready: queue.SimpleQueue[tuple[DeviceSlot, SampleSource]] = queue.SimpleQueue()
        self._on_ready = on_ready
        """Called after a device is queued for the loop: wakes an idle loop."""
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._opening: set[int] = set()
        self._new: list[DeviceSlot] = []
        """Discovered devices not yet handed to the loop."""
        self._monitor: Any = None
        self._thread: threading.Thread | None = None
        self._udev_thread: threading.Thread | None = None
        if use_udev:
            self._monitor = _udev_monitor()

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="hotplug", daemon=True)
        self._thread.start()
        if self._monitor is not None:
            self._udev_thread = threading.Thread(target=self._udev, name="udev", daemon=True)
            self._udev_thread.start()

    def poke(self) -> None:
        """Look for absent devices now (a udev event, or a test)."""
        self._wake.set()

    def scan_once(self) -> int:
        """Try to open every absent device once, and any new one when devices
        were discovered rather than named; returns how many were opened."""
        opened = 0
        slots = self._slots()
        if self._discover is not None:
            known = {s.config.spec for s in slots} | {
                s.config.spec for s in self._new if s.config.spec
            }
            try:
                found = self._discover()
            except Exception:
                log.exception("discovery_failed")
                found = []
            for spec in found:
                if spec not in known:
                    slot = DeviceSlot(config=DeviceConfig(spec), spec=parse_spec(spec), name=spec)
                    self._new.append(slot)
        candidates = [*slots, *[s for s in self._new if id(s) not in self._opening]]
        for slot in candidates:
            if slot.state != "absent" or slot.spec.finite or id(slot) in self._opening:
                continue
            if slot.run is not None or (slot.thread is not None and slot.thread.is_alive()):
                continue  # still winding down its last frame
            try:
                source = self._open(slot)
            except StictionError as exc:
                log.debug("reopen_failed device=%s error=%s", slot.name, exc)
                continue
            except Exception:
                log.exception("reopen_crashed device=%s", slot.name)
                continue
            self._opening.add(id(slot))
            self.ready.put((slot, source))
            self._on_ready()
            opened += 1
        return opened

    def installed(self, slot: DeviceSlot) -> None:
        self._opening.discard(id(slot))
        if slot in self._new:
            self._new.remove(slot)

    def _run(self) -> None:
        while not self._stop.is_set():
            self._wake.wait(RETRY_S)
            self._wake.clear()
            if self._stop.is_set():
                break
            self.scan_once()

    def _udev(self) -> None:
        monitor = self._monitor
        while not self._stop.is_set():
            try:
                device = monitor.poll(timeout=0.5)
            except Exception:
                log.warning("udev_monitor_failed (falling back to polling)")
                return
            if device is not None and device.action == "add":
                log.info("udev_add node=%s", device.device_node)
                self.poke()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        for t in (self._thread, self._udev_thread):
            if t is not None:
                t.join(timeout=1.0)


def _udev_monitor() -> Any:
    try:
        import pyudev

        context = pyudev.Context()
        monitor = pyudev.Monitor.from_netlink(context)
        monitor.filter_by("hidraw")
        monitor.filter_by("input")
        monitor.start()
        return monitor
    except Exception as exc:  # no udev in containers and test machines: poll instead
        log.info("udev_unavailable error=%s (retrying every %.0f s)", exc, RETRY_S)
        return None
