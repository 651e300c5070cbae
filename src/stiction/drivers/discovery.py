"""Every tablet and touchpad on this machine, and which backend reads each one.

A tablet the kernel drives shows up twice: as a /dev/hidrawN node (its raw
HID reports) and as one or more /dev/input/eventN nodes (what the kernel
driver made of them). Both hang below the same HID device in sysfs
(``.../0003:256C:006D.0005/hidraw/hidraw3`` and
``.../0003:256C:006D.0005/input/input17/event12``), which is how they are
paired here. Each pair is read once, through the backend this rule picks:

1. evdev when every pen/touch event node of the device carries a size (the
   kernel driver's absinfo resolution, or stiction's evdev size table): the
   kernel's quirks and descriptor fix-ups come for free, and ``grab`` can
   stop the desktop cursor;
2. else hidraw when the HID path has a size (descriptor, device table, or a
   vendor initialisation that reports it);
3. else evdev, whose size the user must then configure.

A device with only one kind of node is read through that one. The daemon's
``backend`` setting (``[[devices]] backend``, or a ``hidraw:``/``evdev:``
spec prefix) overrides the rule for a device it names.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import logging
import os
import re
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from stiction.drivers.info import DeviceInfo
from stiction.errors import StictionError

if TYPE_CHECKING:
    from stiction.drivers.evdev.description import DeviceDescription

log = logging.getLogger(__name__)

# Each backend module offers ``discover() -> list[DeviceInfo]``.
BACKENDS = ("stiction.drivers.hid", "stiction.drivers.evdev")
SYSFS_CLASS = Path("/sys/class")

# A HID device's sysfs name: BUS:VENDOR:PRODUCT.INSTANCE, in upper-case hex.
_HID_NAME = re.compile(r"^[0-9A-F]{4}:[0-9A-F]{4}:[0-9A-F]{4}\.[0-9A-F]{4}$")


def discover_nodes() -> list[DeviceInfo]:
    """What each backend finds, unpaired (the fields discovery adds are None)."""
    found: list[DeviceInfo] = []
    for name in BACKENDS:
        module = importlib.import_module(name)
        discover = getattr(module, "discover", None)
        if discover is None:
            continue
        try:
            found.extend(discover())
        except Exception as exc:  # a backend that fails must not hide the other's devices
            log.warning("discovery_failed backend=%s error=%s: %s", name, type(exc).__name__, exc)
    return found


def discover_all(prefer: Callable[[DeviceInfo], str | None] | None = None) -> list[DeviceInfo]:
    """Every node, paired with its siblings and marked `chosen` (or not) with a reason.

    `prefer` names the backend the user asked for a node's device (None: the rule).
    """
    return choose([_annotated(info) for info in discover_nodes()], prefer)


def _annotated(info: DeviceInfo) -> DeviceInfo:
    try:
        return annotate(info)
    except Exception as exc:  # one odd node must not hide the others: it just stays unpaired
        log.warning("probe_failed path=%s error=%s: %s", info.path, type(exc).__name__, exc)
        return info


def annotate(info: DeviceInfo, sysfs: Path = SYSFS_CLASS) -> DeviceInfo:
    """`info` with its HID device and whether its backend knows the size."""
    where: str | None = None
    if info.backend == "evdev":
        where = evdev_size(info.path)
    elif info.backend == "hidraw":
        where = hidraw_size(info)
    return dataclasses.replace(
        info,
        hid_device=hid_device_of(info, sysfs),
        sized=None if where is None else bool(where),
        size_from=where or None,
    )


def hid_device_of(info: DeviceInfo, sysfs: Path = SYSFS_CLASS) -> str | None:
    """The sysfs path of the HID device above a hidraw or event node (None: not HID)."""
    cls = "hidraw" if info.backend == "hidraw" else "input"
    try:
        here = os.path.realpath(sysfs / cls / os.path.basename(info.path))
    except (OSError, ValueError):
        return None
    while here not in ("/", ""):
        if _HID_NAME.match(os.path.basename(here)):
            return here
        here = os.path.dirname(here)
    return None


def evdev_size(path: str, size_mm: tuple[float, float] | None = None) -> str | None:
    """Where an event node's size comes from: "kernel" (absinfo resolution), "table"
    (stiction's evdev size table), "config" (`size_mm`), "" (nowhere) or None when
    the node cannot be opened to tell."""
    import evdev

    from stiction.drivers.evdev import sizes
    from stiction.drivers.evdev.device import describe

    try:
        dev = evdev.InputDevice(path)
    except (OSError, SystemError):
        return None
    try:
        raw = describe(dev)
        if sizes.unusable(raw) is not None:
            return ""  # no size makes it a surface (a pad, an inverted axis): not sized
        if _has_resolution(raw) and size_mm is None and sizes.kernel_size_plausible(raw):
            return "kernel"
        if not _has_resolution(sizes.apply(raw, size_mm)):
            return ""
        return "config" if size_mm is not None else "table"
    except (OSError, SystemError, StictionError):
        return None
    finally:
        with contextlib.suppress(OSError):
            dev.close()


def _has_resolution(desc: DeviceDescription) -> bool:
    cx, cy = desc.position_codes
    ax, ay = desc.axes.get(cx), desc.axes.get(cy)
    return ax is not None and ay is not None and ax.resolution > 0 and ay.resolution > 0


def hidraw_size(info: DeviceInfo) -> str | None:
    """Where the HID path's size comes from: "descriptor" (the descriptor, or the
    device table, maps without a size given), "vendor-init" (reported when the
    node is opened), "" (nowhere) or None when that cannot be told."""
    if info.kind in ("other", "unknown"):
        return None
    from stiction.drivers.hid.devices import lookup

    entry = lookup(info.vid, info.pid)
    if entry is not None and entry.init == "huion-string-descriptor":
        return "vendor-init"
    if info.problem is None:
        return "descriptor"  # discovery built the report mapping: the size is known
    maps = hidraw_maps(info, None)
    if maps is None:
        return None
    return "descriptor" if maps[0] else "" if maps[1] else None


def hidraw_maps(info: DeviceInfo, size_m: tuple[float, float] | None) -> tuple[bool, bool] | None:
    """Whether the live node's descriptor maps to contacts with `size_m` (None: with
    what it and the catalogue know), and whether it maps given any size; None when
    the node cannot be read. The second answer tells "lacks a size" from "is not
    a pen at all", for discovery and `stiction doctor` alike."""
    import hidraw

    from stiction.drivers.hid.descriptor import parse_descriptor
    from stiction.drivers.hid.devices import lookup
    from stiction.drivers.hid.stream import ReportStream

    dev = hidraw.device()
    try:
        dev.open_path(info.path.encode())
        raw = bytes(dev.get_report_descriptor())
        entry = lookup(info.vid, info.pid, name=info.name, descriptor=raw)
        desc = parse_descriptor(entry.descriptor if entry and entry.descriptor else raw)
    except (OSError, ValueError, StictionError):
        return None
    finally:
        with contextlib.suppress(OSError, ValueError):
            dev.close()

    def maps(size: tuple[float, float] | None) -> bool:
        try:
            ReportStream(desc, info.name, size, entry)
        except StictionError:
            return False
        return True

    given = maps(size_m)
    return given, given or maps((0.1, 0.1))


def _usable(info: DeviceInfo) -> bool:
    """A node that could read a pen or touch surface at all."""
    return info.kind not in ("other", "unknown")


def _group_key(info: DeviceInfo) -> str:
    return info.hid_device or f"node:{info.path}"


def _decide(hid: list[DeviceInfo], ev: list[DeviceInfo], wish: str | None) -> tuple[str, str]:
    """(backend, why) for one physical device with pen/touch nodes on both backends."""
    if wish in ("hidraw", "evdev"):
        return wish, f"the config asks for backend = {wish!r}"
    if all(i.sized for i in ev):
        if all(i.size_from == "kernel" for i in ev):
            return "evdev", "the kernel driver knows it: its evdev node reports a resolution"
        return "evdev", "its evdev node has a size (stiction's evdev size table)"
    sized = [i for i in hid if i.sized]
    if sized:
        lacking = "has no size" if any(i.sized is False for i in ev) else "cannot be read"
        vendor = sized[0].size_from == "vendor-init"
        where = "vendor initialisation" if vendor else "descriptor (or device table)"
        return "hidraw", f"its evdev node {lacking}; the HID {where} gives the size"
    if any(i.sized is None for i in hid + ev):
        return "evdev", "the nodes could not be opened to tell their sizes; evdev by default"
    return "evdev", "neither node has a size (configure size_mm); evdev by default"


def choose(
    nodes: Iterable[DeviceInfo], prefer: Callable[[DeviceInfo], str | None] | None = None
) -> list[DeviceInfo]:
    """Mark each node `chosen` or not, with a reason, per the module's rule (same order)."""
    nodes = list(nodes)
    groups: dict[str, list[DeviceInfo]] = {}
    for info in nodes:
        groups.setdefault(_group_key(info), []).append(info)
    verdict: dict[str, tuple[bool, str]] = {}
    for members in groups.values():
        hid = [i for i in members if i.backend == "hidraw" and _usable(i)]
        ev = [i for i in members if i.backend == "evdev" and _usable(i)]
        for i in members:
            if not _usable(i):
                verdict[i.path] = (False, "no pen or touch surface on this node")
        if not (hid and ev):
            only = "hidraw" if hid else "evdev"
            why = "no evdev node for it" if hid else "no hidraw node for it"
            for i in hid or ev:
                verdict[i.path] = (True, f"{why}: read through {only}")
            continue
        wishes = [w for w in (prefer(i) for i in hid + ev) if w] if prefer else []
        backend, why = _decide(hid, ev, wishes[0] if wishes else None)
        picked = hid if backend == "hidraw" else ev
        names = ", ".join(i.path for i in picked)
        for i in hid + ev:
            if i in picked:
                verdict[i.path] = (True, why)
            else:
                verdict[i.path] = (False, f"read through {names} ({backend}): {why}")
    return [
        dataclasses.replace(i, chosen=verdict[i.path][0], reason=verdict[i.path][1]) for i in nodes
    ]


def select(
    nodes: Iterable[DeviceInfo], matches: Callable[[DeviceInfo], bool], backend: str | None = None
) -> list[DeviceInfo]:
    """The nodes that read the devices `matches` names (by VID:PID or name), in order.

    A device matches when any of its nodes does (an evdev node is often named
    "<product> Pen"); of a matching device this gives the pen/touch nodes of
    `backend`, or without one the chosen nodes.
    """
    nodes = list(nodes)
    keys = {_group_key(i) for i in nodes if matches(i)}
    out = []
    for i in nodes:
        if _group_key(i) not in keys or not _usable(i):
            continue
        if (i.backend == backend) if backend else bool(i.chosen):
            out.append(i)
    return out
