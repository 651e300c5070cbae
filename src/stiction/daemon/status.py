"""The daemon's answers to queries: stats, devices, params, ping, snapshot.

Each function builds one typed reply (protocol.py's TypedDicts) from the
daemon's state and changes nothing. They read the daemon only through
`Observed`, the read-only view below, so what a reply depends on is written
down in one place and the loop (daemon/service.py) is not imported here.
They run on the loop thread between ticks (daemon/ops.py's queries).
"""

from __future__ import annotations

import time
from typing import Any, Protocol, cast

from stiction import __version__, protocol
from stiction.daemon.clock import Schedule
from stiction.daemon.control import ControlServer
from stiction.daemon.device_set import mapping_config
from stiction.daemon.devices import DeviceSlot
from stiction.daemon.options import Options
from stiction.daemon.prepare import Preparer
from stiction.daemon.publisher import Sink
from stiction.daemon.stats import Window
from stiction.daemon.wake import Waker
from stiction.scene.backend import SimulatorBackend
from stiction.scene.pipeline import Pipeline


class Observed(Protocol):
    """What the replies read of the daemon (daemon/service.py's Daemon)."""

    @property
    def opts(self) -> Options: ...
    @property
    def started(self) -> float:
        """time.monotonic() when the daemon was made (the uptime counts from it)."""
        ...

    @property
    def slots(self) -> list[DeviceSlot]: ...
    @property
    def publisher(self) -> Sink | None: ...
    @property
    def control(self) -> ControlServer | None: ...
    @property
    def schedule(self) -> Schedule: ...
    @property
    def waker(self) -> Waker: ...
    @property
    def realtime(self) -> int: ...
    @property
    def jitter(self) -> Window: ...
    @property
    def latency(self) -> Window: ...
    @property
    def cost(self) -> Window: ...
    @property
    def cost_cpu(self) -> Window: ...
    @property
    def counters(self) -> dict[str, int]: ...
    @property
    def preparer(self) -> Preparer | None: ...
    @property
    def pipeline(self) -> Pipeline: ...
    @property
    def defaults(self) -> dict[str, Any]: ...
    @property
    def backend(self) -> SimulatorBackend: ...
    @property
    def last_tick(self) -> int: ...
    @property
    def last_frames(self) -> dict[str, protocol.FrameWire]: ...


def stats(d: Observed) -> protocol.StatsWire:
    pub = d.publisher
    devices: dict[str, protocol.DeviceStatsWire] = {}
    for slot in d.slots:
        device: protocol.DeviceStatsWire = {
            "state": reported_state(slot),
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
    control = d.control
    schedule = d.schedule
    prep = d.preparer
    return {
        "uptime_s": round(time.monotonic() - d.started, 3),
        "rate": d.opts.rate,
        "clock": d.opts.clock,
        "ticks": schedule.ticks,
        "late_ticks": schedule.late,
        "skipped_deadlines": schedule.skipped,
        "idle_deadlines": schedule.slept,
        "idle_wakes": d.waker.wakes,
        "realtime": d.realtime,
        "late_threshold_ms": schedule.late_threshold * 1e3,
        "jitter_ms": summary(d.jitter),
        "latency_ms": summary(d.latency),
        "tick_cost_ms": summary(d.cost),
        "tick_cpu_ms": summary(d.cost_cpu),
        "prepared_hits": prep.hits if prep else 0,
        "prepared_misses": prep.misses if prep else 0,
        "unprepared": prep.unprepared if prep else 0,
        "published": pub.sent if pub else 0,
        "publish_dropped": pub.dropped if pub else 0,
        "control_requests": control.requests if control else 0,
        "control_errors": control.errors if control else 0,
        "scene_loads": d.counters["scene_loads"],
        "scene_errors": d.counters["scene_errors"],
        "reloads": d.counters["reloads"],
        "devices": devices,
    }


def devices(d: Observed) -> list[protocol.DeviceWire]:
    return [
        {
            "name": slot.name,
            "spec": slot.config.spec,
            "kind": slot.kind,
            "state": reported_state(slot),
            "surface_m": list(slot.surface_size) if slot.surface_size else None,
            "mapping": mapping_config(slot).mode,
        }
        for slot in d.slots
    ]


def params(d: Observed) -> protocol.ParamsReply:
    materials = d.pipeline.wire()["materials"]
    return protocol.params_reply(d.defaults, d.backend.integrator, materials)


def ping(d: Observed) -> protocol.PingReply:
    return protocol.ping_reply(d.last_tick, __version__, d.opts.rate, d.opts.keepalive)


def snapshot(d: Observed) -> protocol.SnapshotReply:
    return protocol.snapshot_reply(d.last_tick, d.pipeline.wire(), d.last_frames, d.opts.keepalive)


def reported_state(slot: DeviceSlot) -> protocol.DeviceState:
    """`waiting` for a device never opened yet (a typo is refused at start), else the state."""
    if slot.state == "absent" and not slot.opened:
        return "waiting"
    return cast(protocol.DeviceState, slot.state)


def summary(window: Window) -> protocol.Summary:
    """A window's p50/p99/max in milliseconds, as the stats reply carries them."""
    return cast(protocol.Summary, window.summary(1e3))
