"""The daemon's parts on their own (issue 15): no sockets, no loop.

DeviceSet and SceneState are built here without a Daemon, from the state
they are given, which is what lets the loop in service.py stay the only
owner of the schedule, the clock and the published frames.
"""

from __future__ import annotations

import logging
from typing import Any

import pytest
from daemon_support import ListSource, opener_for, stroke

from stiction import protocol
from stiction.daemon.device_set import DeviceSet, mapping_config
from stiction.daemon.devices import DeviceConfig
from stiction.daemon.mapping import AreaMapping, make_mapping
from stiction.daemon.options import Options
from stiction.daemon.scene_state import SceneState
from stiction.daemon.status import reported_state
from stiction.daemon.wake import Waker
from stiction.errors import StictionError
from stiction.scene.load import default_scene

DISPLAY = (1920, 1080)


def _device_set(
    sources: dict[str, Any], last_frames: dict[str, Any] | None = None, **opts: Any
) -> DeviceSet:
    o = Options(hotplug=False, devices=[DeviceConfig(spec) for spec in sources], **opts)
    frames: dict[str, Any] = {} if last_frames is None else last_frames
    return DeviceSet(o, opener_for(sources), Waker(), frames)


def test_two_devices_of_one_name_are_numbered_and_share_the_first_ones_time() -> None:
    first = ListSource(stroke(t0=5.0, n=3))
    second = ListSource(stroke(t0=100.0, n=3))
    stale = {"test-pen": protocol.frame(0, -1, 0.0, None, "test-pen", [])}
    devices = _device_set(
        {"synthetic:a": first, "synthetic:b": second}, last_frames=stale, clock="virtual"
    )
    devices.open(DISPLAY, realtime=0)
    assert [s.name for s in devices.slots] == ["test-pen", "test-pen#2"]
    assert stale == {}  # a device (re)opened is announced at once, not compared with old frames
    assert devices.align_virtual() == 5.0
    assert [s.clock.offset for s in devices.slots] == [0.0, 5.0 - 100.0]
    assert devices.hotplug is None  # a virtual clock never watches for devices


def test_a_live_device_missing_at_start_waits_and_a_replay_missing_is_refused() -> None:
    devices = _device_set({"/dev/hidraw99": StictionError("no such device")})
    devices.open(DISPLAY, realtime=0)
    (slot,) = devices.slots
    assert (slot.state, slot.run, reported_state(slot)) == ("absent", None, "waiting")

    refused = _device_set({"synthetic:x": StictionError("no such stroke")}, clock="virtual")
    with pytest.raises(StictionError, match="no such stroke"):
        refused.open(DISPLAY, realtime=0)


def test_a_live_device_is_refused_with_a_virtual_clock() -> None:
    devices = _device_set({"/dev/hidraw0": ListSource([])}, clock="virtual")
    with pytest.raises(StictionError, match="--clock virtual needs replay: or synthetic:"):
        devices.open(DISPLAY, realtime=0)


def _scene_state(devices: DeviceSet) -> tuple[SceneState, list[tuple[int, int]]]:
    """A SceneState and the display of every scene it published (after the swap)."""
    published: list[tuple[int, int]] = []
    made: list[SceneState] = []
    state = SceneState(
        devices.opts,
        devices,
        devices.waker,
        publish=lambda: published.append(made[0].pipeline.scene.display),
        last_tick=lambda: 7,
        reload_keys=lambda: None,
    )
    made.append(state)
    return state, published


def test_a_scene_with_another_display_remaps_the_devices_and_is_published() -> None:
    devices = _device_set({"synthetic:a": ListSource(stroke(n=3))}, clock="virtual")
    state, published = _scene_state(devices)
    devices.open(state.pipeline.scene.display, realtime=0)
    (slot,) = devices.slots
    before = slot.run.mapping.px_per_m

    smaller = (800, 600)
    state.apply_pipeline(state.prepare_scene(default_scene(smaller)))
    expected = make_mapping(slot.surface_size, smaller, mapping_config(slot), slot.name)
    assert isinstance(expected, AreaMapping)  # a pen maps by area
    assert slot.run.mapping.px_per_m == expected.px_per_m != before
    assert published == [smaller] and state.counters["scene_loads"] == 2


def test_a_refused_change_is_counted_and_changes_nothing() -> None:
    state, published = _scene_state(_device_set({}))
    running = state.pipeline
    with pytest.raises(StictionError):
        state.load_scene_text("this is [not toml", "<test>")
    with pytest.raises(StictionError):
        state.prepare_params({"mu_s": -1.0}, None)
    assert state.pipeline is running and published == [] and state.generation == 0
    # A scene that cannot be read counts; a refused parameter value is the
    # op's error reply, not a scene error.
    assert state.counters["scene_errors"] == 1


def test_posted_changes_run_in_order_and_a_failing_one_does_not_stop_the_rest(
    caplog: pytest.LogCaptureFixture,
) -> None:
    state, _ = _scene_state(_device_set({}))
    ran: list[str] = []

    def broken() -> None:
        raise RuntimeError("a bug")

    state.post(lambda: ran.append("first"))
    state.post(broken)
    state.post(lambda: ran.append("third"))
    assert ran == []  # nothing runs until the loop's tick boundary
    with caplog.at_level(logging.ERROR, logger="stiction.daemon"):
        state.run_tasks()
    assert ran == ["first", "third"]
    assert "task_failed" in caplog.text
    assert state.tasks.empty()
