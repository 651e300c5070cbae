"""Which event nodes are pens, touchpads or touchscreens, without opening them.

Capabilities come from sysfs (``/sys/class/input/eventN/device/capabilities``
and ``properties``), which any user may read, so discovery can also report
the nodes stiction may not open and say why; udev's ID_INPUT_* tags are
added where pyudev finds them.
"""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

from stiction.drivers.evdev.description import AbsAxis, DeviceDescription
from stiction.drivers.info import DeviceInfo

SYSFS_INPUT = Path("/sys/class/input")

log = logging.getLogger(__name__)


def _bitmask(text: str) -> frozenset[int]:
    """A sysfs capability mask: space-separated hex longs, most significant first."""
    words = text.split()
    out: set[int] = set()
    nbits = 64 if sys.maxsize > 2**32 else 32
    for i, word in enumerate(reversed(words)):
        v = int(word, 16)
        b = 0
        while v:
            if v & 1:
                out.add(i * nbits + b)
            v >>= 1
            b += 1
    return frozenset(out)


def _read(p: Path) -> str:
    try:
        return p.read_text().strip()
    except OSError:
        return ""


def _udev(node: str) -> dict[str, str]:
    try:
        import pyudev

        ctx = pyudev.Context()
        dev = pyudev.Devices.from_device_file(ctx, node)
        return {k: str(v) for k, v in dev.properties.items() if k.startswith("ID_INPUT")}
    except Exception:  # no udev database (containers): sysfs bits still classify
        return {}


def describe_sysfs(event_dir: Path, node: str) -> DeviceDescription:
    """What sysfs says about one event node (no absinfo ranges: those need the node)."""
    dev = event_dir / "device"
    ids = [_read(dev / "id" / f) or "0" for f in ("bustype", "vendor", "product", "version")]
    caps = dev / "capabilities"
    abs_codes = _bitmask(_read(caps / "abs") or "0")
    return DeviceDescription(
        name=_read(dev / "name"),
        bustype=int(ids[0], 16),
        vendor=int(ids[1], 16),
        product=int(ids[2], 16),
        version=int(ids[3], 16),
        properties=_bitmask(_read(dev / "properties") or "0"),
        keys=_bitmask(_read(caps / "key") or "0"),
        axes={c: AbsAxis(0, 0, 0) for c in abs_codes},
        udev=_udev(node),
    )


def _problem(node: str) -> str | None:
    if not os.path.exists(node):
        return f"{node} does not exist (no udev, or a container without /dev/input)"
    if not os.access(node, os.R_OK):
        return (
            f"no read permission on {node}: install stiction's udev rule (udev/) so the "
            "logged-in user gets access, or join the 'input' group"
        )
    return None


def discover(sysfs: Path = SYSFS_INPUT) -> list[DeviceInfo]:
    out: list[DeviceInfo] = []
    try:
        entries = sorted(sysfs.glob("event*"), key=lambda p: int(p.name[5:] or 0))
    except (OSError, ValueError):
        return out
    for ev in entries:
        node = f"/dev/input/{ev.name}"
        try:
            desc = describe_sysfs(ev, node)
        except Exception as exc:  # one odd node must not hide the others
            log.warning("probe_failed path=%s error=%s: %s", node, type(exc).__name__, exc)
            continue
        kind = desc.kind
        if kind == "other":
            continue
        out.append(
            DeviceInfo(
                path=node,
                backend="evdev",
                vid=desc.vendor,
                pid=desc.product,
                name=desc.name,
                kind=kind,
                problem=_problem(node),
            )
        )
    return out
