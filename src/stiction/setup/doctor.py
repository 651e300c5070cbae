"""`stiction doctor`: can stiction open each tablet and touchpad here, and if not, why.

Every candidate that discovery finds (both backends) is opened with the
same production code the daemon uses (`open_hidraw`, `open_device`), then
closed again. When that fails, the cause is pinned down by the stage that
failed rather than by parsing messages:

1. the node itself, opened the way hidapi / python-evdev open it: EACCES or
   EPERM is a permission problem (the udev rule);
2. the production open without a grab: for evdev a failure here with the
   node readable is a missing size when the position axes still have no
   resolution after the configured size and the size table are applied; for
   hidraw a table device with a vendor initialisation is re-checked by
   running that initialisation alone (the Huion string descriptor read
   through pyusb, which needs the USB node);
3. for evdev, the production open *with* a grab: it opens fine but cannot be
   grabbed means another program holds it exclusively, and then stictiond
   would receive no events at all, grab or not. The doctor's own grab lasts
   only as long as the open.

Sizes, grabs and backends configured in the daemon's config file are
applied as the daemon would, so a device the user has already fixed reports
"ok". Each finding says whether the daemon reads its device through this
node (stiction.drivers.discovery pairs a tablet's hidraw and evdev nodes and
picks one); a problem on the node not chosen is reported but does not make
the device unusable.
"""

from __future__ import annotations

import contextlib
import errno
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stiction.drivers.info import DeviceInfo
from stiction.errors import StictionError
from stiction.setup.files import install_rules_command

PERMISSION = "permission"
BUSY = "busy"
SIZE = "no-size"
VENDOR_INIT = "vendor-init"
GONE = "gone"
OTHER = "other"


@dataclass(frozen=True, slots=True)
class Finding:
    """One device: `problem` is None when stiction can open it, else one of the names above."""

    path: str
    backend: str
    vid_pid: str
    name: str
    kind: str
    problem: str | None = None
    detail: str = ""
    fix: str = ""
    chosen: bool = True
    reason: str = ""
    """Whether stictiond reads the device through this node, and why (or what it
    reads instead): a device has a hidraw and an evdev node, and only one is used."""

    @property
    def ok(self) -> bool:
        return self.problem is None

    @property
    def blocks(self) -> bool:
        """A problem that stops the device being read (one on an unused node does not)."""
        return self.chosen and not self.ok

    def as_json(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "backend": self.backend,
            "vid_pid": self.vid_pid,
            "name": self.name,
            "kind": self.kind,
            "ok": self.ok,
            "problem": self.problem,
            "detail": self.detail,
            "fix": self.fix,
            "chosen": self.chosen,
            "reason": self.reason,
        }


@dataclass(frozen=True, slots=True)
class Configured:
    """What the daemon's config says about one device path."""

    surface_size: tuple[float, float] | None = None
    grab: bool = False
    backend: str | None = None


# ----------------------------------------------------------------- config


Settings = dict[str, Configured]


def load_configured(config: Path | None) -> tuple[Settings, Settings, Settings]:
    """Per-path, per-vid:pid and per-name settings from the daemon config (empty
    without one); names are lower case, matched as the daemon does (contained)."""
    if config is None or not config.exists():
        return {}, {}, {}
    from stiction.daemon.config import load_options
    from stiction.daemon.devices import parse_spec

    by_path: dict[str, Configured] = {}
    by_id: dict[str, Configured] = {}
    by_name: dict[str, Configured] = {}
    for dev in load_options(config).devices:
        spec = parse_spec(dev.spec)
        value = Configured(dev.surface_size, dev.grab, dev.backend or spec.backend)
        if spec.kind in ("hidraw", "evdev"):
            # /dev/input/by-id/... names the same node discovery lists as eventN
            by_path[os.path.realpath(spec.target)] = value
        elif spec.kind == "vidpid":
            by_id[spec.target] = value
        elif spec.kind == "name":
            by_name[spec.target.lower()] = value
    return by_path, by_id, by_name


# ------------------------------------------------------------------ probes


def _open_errno(path: str, flags: int) -> int | None:
    """errno of opening the node as the reading library does, None if it opens."""
    try:
        fd = os.open(path, flags | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        return exc.errno or errno.EIO
    os.close(fd)
    return None


def _node_problem(info: DeviceInfo) -> Finding | None:
    # hidapi opens O_RDWR; python-evdev tries O_RDWR and falls back to O_RDONLY.
    code = _open_errno(info.path, os.O_RDWR)
    if code is not None and info.backend == "evdev" and code in (errno.EACCES, errno.EPERM):
        code = _open_errno(info.path, os.O_RDONLY)
    if code is None:
        return None
    if code in (errno.EACCES, errno.EPERM):
        return _finding(
            info,
            PERMISSION,
            f"you may not open {info.path} ({os.strerror(code)})",
            f"install stiction's udev rule: `{install_rules_command()}`, then re-plug the device "
            "(the rule gives the logged-in user access; no group or root needed)",
        )
    if code in (errno.ENOENT, errno.ENODEV, errno.ENXIO):
        return _finding(
            info,
            GONE,
            f"{info.path} disappeared while checking ({os.strerror(code)})",
            "re-plug the device and run `stiction doctor` again",
        )
    return _finding(
        info,
        OTHER,
        f"opening {info.path} fails: {os.strerror(code)}",
        "check `dmesg` for errors from the device's driver",
    )


def _finding(info: DeviceInfo, problem: str | None, detail: str, fix: str = "") -> Finding:
    return Finding(
        info.path,
        info.backend,
        info.vid_pid,
        info.name,
        info.kind,
        problem,
        detail,
        fix,
        chosen=info.chosen is not False,
        reason=info.reason or "",
    )


def _size_fix(info: DeviceInfo, config: Path) -> str:
    return (
        "measure the active area and add to "
        f'{config}:  [[devices]]  spec = "{info.path}"  size_mm = [width, height] '
        "(millimetres, e.g. [216, 135]); then `stiction doctor` again "
        "(or send the size to stiction's device tables so nobody else has to)"
    )


def _evdev_lacks_size(path: str, size_mm: tuple[float, float] | None) -> bool:
    """True if, with the size table and `size_mm` applied, X/Y still have no resolution."""
    import evdev

    from stiction.drivers.evdev import sizes
    from stiction.drivers.evdev.device import describe

    try:
        dev = evdev.InputDevice(path)
    except OSError:
        return False
    try:
        desc = sizes.apply(describe(dev), size_mm)
    except (OSError, StictionError):
        return False
    finally:
        with contextlib.suppress(OSError):
            dev.close()
    cx, cy = desc.position_codes
    ax, ay = desc.axes.get(cx), desc.axes.get(cy)
    return ax is not None and ay is not None and not (ax.resolution > 0 and ay.resolution > 0)


def check_evdev(info: DeviceInfo, conf: Configured, config: Path) -> Finding:
    from stiction.drivers.evdev import open_device

    size_mm = (
        (conf.surface_size[0] * 1e3, conf.surface_size[1] * 1e3) if conf.surface_size else None
    )
    try:
        open_device(info.path, grab=False, size_mm=size_mm).close()
    except StictionError as exc:
        if _evdev_lacks_size(info.path, size_mm):
            return _finding(
                info,
                SIZE,
                "the device reports no resolution, so its physical size is unknown",
                _size_fix(info, config),
            )
        return _finding(info, OTHER, str(exc), "run `stiction -v doctor` and report the message")
    try:
        open_device(info.path, grab=True, size_mm=size_mm).close()
    except StictionError as exc:
        return _finding(
            info,
            BUSY,
            f"another program holds {info.path} exclusively (EVIOCGRAB), so nobody else "
            f"receives its events ({exc})",
            f"find it with `fuser -v {info.path}` (or `sudo fuser -v ...`) and stop it; "
            "if it is a stictiond of yours: `systemctl --user stop stictiond`",
        )
    note = "opens and can be grabbed"
    if conf.grab:
        note += "; grab = true in the config: the desktop cursor will not follow it"
    return _finding(info, None, note)


def _usb_node(path: str) -> str | None:
    """/dev/bus/usb/BBB/DDD above a hidraw node, from udev (None when not on USB)."""
    try:
        import pyudev

        dev = pyudev.Devices.from_device_file(pyudev.Context(), path)
        usb = dev.find_parent("usb", "usb_device")
    except Exception:  # no udev database, or not a USB device
        return None
    return None if usb is None else usb.device_node


def _hid_lacks_size(info: DeviceInfo, size_m: tuple[float, float] | None) -> bool:
    """True if the descriptor maps with some size but not with the one known (if any)."""
    from stiction.drivers.discovery import hidraw_maps

    maps = hidraw_maps(info, size_m)
    return maps is not None and not maps[0] and maps[1]


def check_hidraw(info: DeviceInfo, conf: Configured, config: Path) -> Finding:
    from stiction.drivers.hid import open_hidraw
    from stiction.drivers.hid.devices import lookup

    try:
        open_hidraw(info.path, size_m=conf.surface_size).close()
    except StictionError as exc:
        entry = lookup(info.vid, info.pid)
        if entry is not None and entry.init == "huion-string-descriptor":
            from stiction.drivers.hid.usb_init import huion_init

            try:
                huion_init(entry.vid, entry.pid)
            except StictionError as init_exc:
                node = _usb_node(info.path) or "the tablet's /dev/bus/usb/BBB/DDD node"
                return _finding(
                    info,
                    VENDOR_INIT,
                    "vendor mode not enabled: the Huion initialisation (USB string "
                    f"descriptor 200, else 100, read with pyusb) failed: {init_exc}",
                    f"it needs write access to {node}: `{install_rules_command()}` gives it to the "
                    "logged-in user; re-plug the tablet afterwards",
                )
        if _hid_lacks_size(info, conf.surface_size):
            return _finding(info, SIZE, str(exc), _size_fix(info, config))
        return _finding(info, OTHER, str(exc), "run `stiction -v doctor` and report the message")
    return _finding(info, None, "opens and reads its report descriptor")


def check(info: DeviceInfo, conf: Configured, config: Path) -> Finding:
    """One device, never raising: unexpected failures become an 'other' finding."""
    try:
        node = _node_problem(info)
        if node is not None:
            return node
        if info.backend == "evdev":
            return check_evdev(info, conf, config)
        return check_hidraw(info, conf, config)
    except Exception as exc:  # a diagnostic tool reports, it does not crash
        return _finding(
            info, OTHER, f"unexpected error: {exc!r}", "please report this as a stiction bug"
        )


def diagnose(config: Path) -> list[Finding]:
    """Every candidate device with its finding, in discovery order."""
    from stiction.drivers.discovery import discover_all

    by_path, by_id, by_name = load_configured(config)

    def configured(info: DeviceInfo) -> Configured:
        named = [v for k, v in by_name.items() if k in info.name.lower()]
        found = by_path.get(os.path.realpath(info.path)) or by_id.get(info.vid_pid)
        return found or (named[0] if named else Configured())

    def by_device(info: DeviceInfo) -> str | None:
        """The backend the config asks for a VID:PID or a name (a path is its own)."""
        named = [v for k, v in by_name.items() if k in info.name.lower()]
        return (by_id.get(info.vid_pid) or (named[0] if named else Configured())).backend

    found = discover_all(prefer=by_device)
    return [check(info, configured(info), config) for info in found]
