"""Kernel input devices (evdev) and their recordings as PenSample sources.

The factories below are the contract of stiction.drivers.source; each
returns a SampleSource. Modules are imported inside them so that importing
this package stays cheap.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from stiction.drivers.evdev.device import DeviceSource
    from stiction.drivers.evdev.playback import ReplaySource
    from stiction.drivers.info import DeviceInfo

__all__ = ["discover", "open_device", "replay"]


def replay(
    path: str | Path,
    events_path: str | Path | None = None,
    realtime: bool = False,
    *,
    size_mm: tuple[float, float] | None = None,
) -> ReplaySource:
    """Play an evemu recording (combined, or .desc + .events) or a libinput record YAML.

    `realtime` waits for the recorded timing; otherwise samples come as fast
    as they are consumed. Sample times are the recorded kernel times either
    way. `size_mm` (width, height of the active area) is needed only for a
    device that reports no resolution and is not in the device table.
    """
    from stiction.drivers.evdev.playback import open_replay

    return open_replay(path, events_path, realtime=realtime, size_mm=size_mm)


def open_device(
    path: str | Path,
    grab: bool = False,
    *,
    size_mm: tuple[float, float] | None = None,
) -> DeviceSource:
    """Read a live /dev/input/eventN through python-evdev; `grab` takes it exclusively."""
    from stiction.drivers.evdev.device import DeviceSource

    return DeviceSource(str(path), grab=grab, size_mm=size_mm)


def discover() -> list[DeviceInfo]:
    """Tablets, touchpads and touchscreens among this machine's event nodes."""
    from stiction.drivers.evdev.discovery import discover as _discover

    return _discover()
