"""HID pen tablets, touch screens and touchpads, read from their raw reports.

Factories the daemon calls (the contract in stiction.drivers.source):

- ``open_hidraw(path_or_vidpid)``: a live device through hidapi's hidraw backend
- ``replay(path, realtime)``: a hid-recorder ``.hid`` file
- ``discover()``: the digitizers this machine shows as /dev/hidraw* nodes

Heavy imports (hidapi, pyusb, numpy) happen inside the functions that need them.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from stiction.drivers.hid.report_source import ReportSource
    from stiction.drivers.info import DeviceInfo


def replay(
    path: str | Path,
    realtime: bool = False,
    size_m: tuple[float, float] | None = None,
) -> ReportSource:
    """Replay a hid-recorder file; `size_m` overrides the active area (metres)."""
    from stiction.drivers.hid.playback import open_replay

    return open_replay(path, realtime=realtime, size_m=size_m)


def open_hidraw(
    path_or_vidpid: str,
    size_m: tuple[float, float] | None = None,
    usb_backend: Any = None,
) -> ReportSource:
    """Open a /dev/hidrawN node, or the first digitizer interface of a vid:pid.

    `size_m` overrides the active area (metres); `usb_backend` is a pyusb
    backend object for vendor initialisation over USB (None: libusb).
    """
    from stiction.drivers.hid.hidraw_backend import open_hidraw as _open

    return _open(path_or_vidpid, size_m=size_m, usb_backend=usb_backend)


def discover() -> list[DeviceInfo]:
    """Every hidraw node whose descriptor declares a pen, touch screen or touchpad."""
    from stiction.drivers.hid.hidraw_backend import discover as _discover

    return _discover()


__all__ = ["discover", "open_hidraw", "replay"]
