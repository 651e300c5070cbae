"""Live devices through hidapi's hidraw backend (the `hidraw` module of PyPI `hidapi`).

The hidraw backend reads /dev/hidrawN beside the kernel's own driver, so
the desktop keeps its pointer while stiction reads the same pen; it needs
read access to the node (udev `uaccess`), never root.

hidraw reports carry no timestamp: a sample's time is the monotonic clock
when the read returned. An unplugged device makes the read fail: the
source logs it, closes the handle and raises DeviceError from `samples()`
so that the daemon can reconnect.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import stat
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import DeviceEntry, lookup
from stiction.drivers.hid.pen import device_kind
from stiction.drivers.hid.report_source import ReportSource
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.info import DeviceInfo
from stiction.errors import DescriptorError, DeviceError

log = logging.getLogger(__name__)

READ_TIMEOUT_MS = 100  # how soon a blocked read notices close()
MAX_REPORT = 16384
_VIDPID = re.compile(r"^([0-9a-fA-F]{4}):([0-9a-fA-F]{4})$")


def _hidraw() -> Any:
    try:
        import hidraw
    except ImportError as exc:  # pragma: no cover - hidapi is a dependency
        raise DeviceError(f"the hidapi package (module 'hidraw') is missing: {exc}") from None
    return hidraw


# hidapi's bus_type -> the Linux bus number hid-recorder writes (BUS_USB, ...).
LINUX_BUS = {1: 0x03, 2: 0x05, 3: 0x18, 4: 0x1C}


def bus_of(path: bytes) -> int:
    """The Linux bus number of a hidraw node (0 when hidapi does not say)."""
    for d in _enumerate():
        if d["path"] == path:
            return LINUX_BUS.get(d.get("bus_type", 0), 0)
    return 0


def _enumerate() -> list[dict[str, Any]]:
    """One entry per hidraw node (hidapi lists one per top-level collection)."""
    seen: dict[bytes, dict[str, Any]] = {}
    for d in _hidraw().enumerate():
        seen.setdefault(d["path"], d)
    return list(seen.values())


def resolve(path_or_vidpid: str) -> tuple[bytes, int, int, str]:
    """(hidraw path, vid, pid, product name) for a path or the pen interface of a vid:pid."""
    m = _VIDPID.match(path_or_vidpid.strip())
    devices = _enumerate()
    if m:
        vid, pid = int(m.group(1), 16), int(m.group(2), 16)
        matches = [d for d in devices if d["vendor_id"] == vid and d["product_id"] == pid]
        if not matches:
            raise DeviceError(f"no hidraw device with id {vid:04x}:{pid:04x} found")
        # A tablet has several interfaces: take the first whose descriptor has a pen/touch.
        for d in sorted(matches, key=lambda d: d["path"]):
            info = _probe(d)
            if info is not None and info.kind != "other":
                return d["path"], vid, pid, d.get("product_string") or ""
        d = matches[0]
        return d["path"], vid, pid, d.get("product_string") or ""
    path = path_or_vidpid.encode()
    for d in devices:
        if d["path"] == path:
            return path, d["vendor_id"], d["product_id"], d.get("product_string") or ""
    if not os.path.exists(path_or_vidpid):
        raise DeviceError(f"{path_or_vidpid}: no such hidraw device")
    # hidapi "opens" anything and then says only "open failed", which the caller
    # explains as a permission problem; a file or /dev/zero is not one.
    real = os.path.realpath(path_or_vidpid)
    if not stat.S_ISCHR(os.stat(real).st_mode) or not os.path.basename(real).startswith("hidraw"):
        raise DeviceError(f"{path_or_vidpid} is not a hidraw device (/dev/hidrawN, or VID:PID)")
    return path, 0, 0, ""


def open_handle(path: bytes) -> Any:
    """An open hidapi handle, or a DeviceError saying how to get access."""
    dev = _hidraw().device()
    try:
        dev.open_path(path)
    except OSError as exc:
        raise DeviceError(
            f"cannot open {path.decode(errors='replace')}: {exc} "
            "(install udev/ rules for uaccess, or check the path)"
        ) from None
    return dev


def read_descriptor(dev: Any, path: bytes) -> bytes:
    """The report descriptor as the kernel holds it (HIDIOCGRDESC)."""
    try:
        return bytes(dev.get_report_descriptor())
    except (OSError, ValueError) as exc:
        raise DeviceError(
            f"{path.decode(errors='replace')}: cannot read the report descriptor: {exc}"
        ) from None


@dataclass(frozen=True, slots=True)
class _Init:
    """What a vendor initialisation changed: a size learned, a new descriptor, a fix-up."""

    size_m: tuple[float, float] | None = None
    descriptor: bytes | None = None
    fixup: Callable[[bytes], bytes | None] | None = None
    proximity_timeout: float | None = None


def _send_init(dev: Any, entry: DeviceEntry, kind: str, data: bytes) -> None:
    """Send one feature or output report; DeviceError naming the entry if refused."""
    try:
        # hidapi reports failure by returning -1 (and sometimes by raising)
        sent = dev.send_feature_report(data) if kind == "feature" else dev.write(data)
        reason = dev.error() if sent < 0 else None
    except (OSError, ValueError) as exc:
        sent, reason = -1, str(exc)
    if sent < 0:
        raise DeviceError(
            f"{entry.name}: vendor initialisation ({kind}:{data.hex()}) failed: "
            f"{reason or 'the device refused the report'}"
        )


def _vendor_init(dev: Any, entry: DeviceEntry | None, usb_backend: Any) -> _Init:
    """Run the catalogue's initialisation for this device: `init`, then its init reports."""
    if entry is None:
        return _Init()
    result = _Init()
    if entry.init == "huion-string-descriptor":
        from stiction.drivers.hid import uclogic
        from stiction.drivers.hid.usb_init import huion_init

        try:
            params = huion_init(entry.vid, entry.pid, backend=usb_backend)
        except DeviceError as exc:
            if entry.init_layer != "generated":
                raise
            # Only OpenTabletDriver's facts ask for it: a device that worked
            # with its own descriptor before the catalogue still does.
            log.warning("%s: %s; reading the device as its descriptor says", entry.name, exc)
        else:
            log.info("%s: Huion parameters %s", entry.name, params)
            result = _Init(
                params.size_m,
                uclogic.pen_descriptor(params),
                uclogic.fixup(params),
                uclogic.PROXIMITY_TIMEOUT_S if params.index == 200 else None,
            )
    elif entry.init is not None:
        kind, _, hexdata = entry.init.partition(":")
        _send_init(dev, entry, kind, bytes.fromhex(hexdata))
    for kind, data in entry.init_reports:
        _send_init(dev, entry, kind, data)
    return result


def _usb_strings(vid: int, pid: int, usb_backend: Any) -> dict[int, str] | None:
    """The USB strings the catalogue matches this id on, read live; None if none or unreadable.

    Unreadable strings are not an error: the device then gets what the
    catalogue says about its id alone, as a recording does.
    """
    from stiction.drivers.catalogue.resolve import string_indices

    indices = string_indices(vid, pid)
    if not indices:
        return None
    from stiction.drivers.hid.usb_init import read_strings

    try:
        return read_strings(vid, pid, indices, backend=usb_backend)
    except (DeviceError, OSError, ValueError) as exc:  # pyusb's USBError is an OSError
        log.info("%04x:%04x: USB strings not read (%s); matching by id alone", vid, pid, exc)
        return None


class HidrawReader:
    """Iterates (monotonic time, report) from an open handle until closed or unplugged.

    hidapi is not safe against closing a handle another thread is reading,
    so close() only asks; the reading generator closes the handle itself
    within READ_TIMEOUT_MS. If no read is running, close() closes at once.
    """

    def __init__(self, dev: Any, label: str, max_len: int) -> None:
        self.dev = dev
        self.label = label
        self.max_len = max_len
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._reading = False
        self._handle_closed = False

    def _close_handle(self) -> None:
        with self._lock:
            if not self._handle_closed:
                self._handle_closed = True
                with contextlib.suppress(OSError):  # a vanished device
                    self.dev.close()

    def request_close(self) -> None:
        self._stop.set()
        with self._lock:
            reading = self._reading
        if not reading:
            self._close_handle()

    def __iter__(self) -> Iterator[tuple[float, bytes | None]]:
        with self._lock:
            if self._handle_closed:
                return
            self._reading = True
        try:
            while not self._stop.is_set():
                try:
                    data = self.dev.read(self.max_len, READ_TIMEOUT_MS)
                except (OSError, ValueError) as exc:
                    log.warning("%s: read failed (%s): device gone, closing", self.label, exc)
                    raise DeviceError(
                        f"{self.label}: device read failed ({exc}): unplugged?"
                    ) from None
                yield time.monotonic(), bytes(data) if data else None
        finally:
            with self._lock:
                self._reading = False
            self._close_handle()


def open_hidraw(
    path_or_vidpid: str,
    size_m: tuple[float, float] | None = None,
    usb_backend: Any = None,
) -> ReportSource:
    """Open a hidraw node (path) or the first pen/touch interface of a vid:pid.

    `usb_backend` is the pyusb backend object used for vendor
    initialisation over USB (None: libusb).
    """
    path, vid, pid, product = resolve(path_or_vidpid)
    dev = open_handle(path)
    try:
        label = f"{product or 'hid device'} ({vid:04x}:{pid:04x}, {path.decode(errors='replace')})"
        own = read_descriptor(dev, path)
        entry = lookup(
            vid, pid, _usb_strings(vid, pid, usb_backend), product or None, descriptor=own
        )
        raw = entry.descriptor if entry and entry.descriptor else own
        init = _vendor_init(dev, entry, usb_backend)
        desc = parse_descriptor(init.descriptor or raw)
        stream = ReportStream(
            desc, label, size_m or init.size_m, entry, init.fixup, init.proximity_timeout
        )
        # A family's generated descriptor describes the normalised report, not
        # what the device sends: size reads by the device's own reports.
        wire = parse_descriptor(own) if entry and entry.family else desc
        max_len = max((r.byte_size for r in wire.input_reports.values()), default=64)
        reader = HidrawReader(dev, label, min(max_len, MAX_REPORT))
    except BaseException:
        dev.close()
        raise
    name = f"hidraw-{Path(path.decode(errors='replace')).name}"
    return ReportSource(name, stream, reader, realtime=False, on_close=reader.request_close)


def _probe(d: dict[str, Any]) -> DeviceInfo | None:
    path: bytes = d["path"]
    spath = path.decode(errors="replace")
    name = d.get("product_string") or d.get("manufacturer_string") or ""
    vid, pid = d["vendor_id"], d["product_id"]
    try:
        dev = open_handle(path)
    except DeviceError:
        # Without access only hidapi's top-level usage page is known.
        digitizer = d.get("usage_page") in (0x0D, 0xFF0D)
        return DeviceInfo(
            spath,
            "hidraw",
            vid,
            pid,
            name,
            "pen" if digitizer else "other",
            "no read access: install the udev rule from udev/ and re-plug the device",
        )
    try:
        raw = read_descriptor(dev, path)
    except DeviceError as exc:
        return DeviceInfo(spath, "hidraw", vid, pid, name, "other", str(exc))
    finally:
        dev.close()
    entry = lookup(vid, pid, name=name, descriptor=raw)  # a pen family fits only its interface
    try:
        desc = parse_descriptor(entry.descriptor if entry and entry.descriptor else raw)
    except DescriptorError as exc:
        return DeviceInfo(spath, "hidraw", vid, pid, name, "other", f"bad descriptor: {exc}")
    kind = device_kind(desc, entry.pen_reports if entry else frozenset())
    problem = None
    # A device the table initialises gets its real descriptor and size only
    # when opened (the Huion string read switches its mode): not a problem.
    if kind != "other" and not (entry and entry.init == "huion-string-descriptor"):
        try:
            ReportStream(desc, name, None, entry)
        except DeviceError as exc:
            problem = str(exc).split(": ", 1)[-1]
    return DeviceInfo(spath, "hidraw", vid, pid, name, kind, problem)


def discover() -> list[DeviceInfo]:
    """Pen, touch screen and touchpad interfaces among the hidraw nodes."""
    try:
        devices = _enumerate()
    except DeviceError:
        return []
    found = []
    for d in sorted(devices, key=lambda d: d["path"]):
        try:
            info = _probe(d)
        except Exception as exc:
            # One node that trips an unforeseen bug is reported alone; the
            # other devices are still found (and a daemon still opens them).
            path = bytes(d.get("path", b"?")).decode(errors="replace")
            log.warning("probe_failed path=%s error=%s: %s", path, type(exc).__name__, exc)
            vid, pid = int(d.get("vendor_id", 0)), int(d.get("product_id", 0))
            problem = f"cannot be probed ({type(exc).__name__}: {exc})"
            name = str(d.get("product_string") or "")
            info = DeviceInfo(path, "hidraw", vid, pid, name, "unknown", problem)
        if info is not None and info.kind != "other":
            found.append(info)
    return found
