"""A device reopened at a configured path may be another device.

The kernel gives /dev/input/eventN and /dev/hidrawN to whatever is plugged in
next, so the node a `--device /dev/input/event5` slot waits for can come back
as someone else's tablet. Before, the slot adopted it with the size configured
for the first device: a silent wrong surface. Now that reopening is refused
with a reason (the size stays the first device's), and without a configured
size the newcomer is read on its own size and the change is logged.
"""

from __future__ import annotations

import logging

import pytest
from daemon_support import ListSource, make_daemon, stroke

from stiction.daemon.devices import DeviceConfig
from stiction.errors import DeviceError


def _reopen(endpoints: tuple[str, str], size: tuple[float, float] | None, newcomer: str) -> tuple:
    first = ListSource(stroke(n=5), name="Wacom Intuos S Pen", size=(0.152, 0.095))
    d = make_daemon(endpoints, {"pen": first}, devices=[DeviceConfig("pen", surface_size=size)])
    slot = d.slots[0]
    assert slot.source is not None and slot.source.name == "Wacom Intuos S Pen"
    other = ListSource(stroke(n=5), name=newcomer, size=(0.1, 0.06))
    return d, slot, other


def test_another_device_at_the_path_is_not_given_the_size_configured_for_the_first(
    endpoints: tuple[str, str],
) -> None:
    d, slot, other = _reopen(endpoints, (0.216, 0.135), "ELAN Touchscreen")
    try:
        with pytest.raises(DeviceError) as info:
            d.device_set.install(slot, other, d.pipeline.scene.display, 0)
        message = str(info.value)
        assert "'ELAN Touchscreen', not 'Wacom Intuos S Pen'" in message and "by-id" in message
        assert "\n" not in message
        assert other.closed.is_set()  # the newcomer is let go at once
        assert slot.source is not other and slot.source.name == "Wacom Intuos S Pen"
    finally:
        d.close()


def test_without_a_configured_size_the_newcomer_is_read_on_its_own_and_logged(
    endpoints: tuple[str, str], caplog: pytest.LogCaptureFixture
) -> None:
    d, slot, other = _reopen(endpoints, None, "ELAN Touchscreen")
    try:
        with caplog.at_level(logging.INFO, logger="stiction.daemon"):
            d.device_set.install(slot, other, d.pipeline.scene.display, 0)
        assert slot.source is other and slot.surface_size == (0.1, 0.06)
        assert slot.source is other
        assert any("device_changed" in r.getMessage() for r in caplog.records)
    finally:
        d.close()


def test_the_same_device_coming_back_keeps_its_configured_size(
    endpoints: tuple[str, str],
) -> None:
    d, slot, _ = _reopen(endpoints, (0.216, 0.135), "unused")
    same = ListSource(stroke(n=5), name="Wacom Intuos S Pen", size=(0.152, 0.095))
    try:
        d.device_set.install(slot, same, d.pipeline.scene.display, 0)
        assert slot.source is same and slot.surface_size == (0.216, 0.135)
    finally:
        d.close()
