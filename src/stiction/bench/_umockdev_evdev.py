"""umockdev's three files for an evdev node, built from a recording.

Written from shared/design/umockdev-evdev.md: the `.ioctl` answers exactly
the requests python-evdev 2.0.0 sends, with the buffer sizes it uses
(umockdev matches the size too); the `.umockdev` file describes sysfs and the
udev database; the `.events` file carries the recorded times with the
microseconds written without leading zeros (umockdev reads them as octal
otherwise). The fault benchmark plugs such nodes in and out (`stiction bench
faults`); the evdev tests mock their devices with the same files.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

from stiction.drivers.evdev.description import EV_ABS, EV_KEY, EV_SYN, DeviceDescription
from stiction.drivers.evdev.evemu import write_events
from stiction.drivers.evdev.recording import Recording

# bytes python-evdev asks for, and the longs of each type the kernel copies back
_TYPE_BYTES = {EV_KEY: 96}
_LONG = 8


@dataclass
class MockFiles:
    node: str
    umockdev: Path
    ioctl: Path
    events: Path
    syspath: str  # the event node's sysfs path (for unplug)
    input_syspath: str


def _mask_bytes(bits: frozenset[int] | set[int], size: int) -> bytes:
    out = bytearray(size)
    for b in bits:
        if b // 8 < size:
            out[b // 8] |= 1 << (b % 8)
    return bytes(out)


def _types(desc: DeviceDescription) -> set[int]:
    types = {EV_SYN}
    if desc.keys:
        types.add(EV_KEY)
    if desc.axes:
        types.add(EV_ABS)
    types.update(t for t, c in desc.other.items() if c)
    return types


def _codes(desc: DeviceDescription, t: int) -> frozenset[int]:
    if t == EV_KEY:
        return desc.keys
    if t == EV_ABS:
        return frozenset(desc.axes)
    if t == EV_SYN:
        return frozenset({0, 1, 3})
    return desc.other.get(t, frozenset())


def ioctl_text(desc: DeviceDescription, node: str) -> str:
    name = desc.name.encode()[:255]
    types = _types(desc)
    lines = [
        f"@DEV {node}",
        "EVIOCGID 0 "
        + struct.pack("<4H", desc.bustype, desc.vendor, desc.product, desc.version).hex(),
        "EVIOCGVERSION 0 " + struct.pack("<i", 0x010001).hex(),
        f"EVIOCGNAME(0) {len(name) + 1} " + (name + bytes(256 - len(name))).hex(),
        "EVIOCGBIT(0) 4 " + _mask_bytes(types, 4).hex(),
        "EVIOCGBIT(0) 8 " + _mask_bytes(types, 96).hex(),
    ]
    for t in sorted(types - {EV_SYN}):
        ret = _TYPE_BYTES.get(t, _LONG)
        lines.append(f"EVIOCGBIT({t}) {ret} " + _mask_bytes(_codes(desc, t), 96).hex())
    for code, a in sorted(desc.axes.items()):
        data = struct.pack("<6i", a.value, a.minimum, a.maximum, a.fuzz, a.flat, int(a.resolution))
        lines.append(f"EVIOCGABS({code}) 0 " + data.hex())
    lines += [
        "EVIOCGPROP(0) 4 " + _mask_bytes(desc.properties, 4).hex(),
        "EVIOCGKEY(0) 96 " + bytes(96).hex(),
        "EVIOCGLED(0) 2 0000",
        "EVIOCGEFFECTS 0 00000000",
    ]
    return "\n".join(lines) + "\n"


def _sysfs_mask(bits: frozenset[int]) -> str:
    """sysfs capability format: hex longs, most significant first, no leading zero words."""
    if not bits:
        return "0"
    words = [0] * (max(bits) // 64 + 1)
    for b in bits:
        words[b // 64] |= 1 << (b % 64)
    return " ".join(f"{w:x}" for w in reversed(words))


def umockdev_text(
    desc: DeviceDescription, num: int, udev: dict[str, str], id_input: bool = True
) -> str:
    """Without `id_input`, udev's own input_id builtin classifies the device."""
    minor = 64 + num
    props = ("E: ID_INPUT=1\n" if id_input else "") + "".join(
        f"E: {k}={v}\n" for k, v in udev.items()
    )
    caps = {
        "ev": _sysfs_mask(frozenset(_types(desc))),
        "key": _sysfs_mask(desc.keys),
        "abs": _sysfs_mask(frozenset(desc.axes)),
        "msc": _sysfs_mask(desc.other.get(4, frozenset())),
        "rel": _sysfs_mask(desc.other.get(2, frozenset())),
    }
    return (
        f"P: /devices/virtual/input/input{num}/event{num}\n"
        f"N: input/event{num}\n"
        f"E: DEVNAME=/dev/input/event{num}\n"
        f"{props}"
        f"E: MAJOR=13\nE: MINOR={minor}\nE: SUBSYSTEM=input\n"
        f"A: dev=13:{minor}\n"
        f"L: device=../../input{num}\n"
        "\n"
        f"P: /devices/virtual/input/input{num}\n"
        f'E: NAME="{desc.name}"\n'
        f"E: PRODUCT={desc.bustype:x}/{desc.vendor:x}/{desc.product:x}/{desc.version:x}\n"
        "E: SUBSYSTEM=input\n"
        f"{props}"
        f"A: name={desc.name}\n"
        f"A: properties={_sysfs_mask(desc.properties)}\n"
        f"A: id/bustype={desc.bustype:04x}\nA: id/vendor={desc.vendor:04x}\n"
        f"A: id/product={desc.product:04x}\nA: id/version={desc.version:04x}\n"
        + "".join(f"A: capabilities/{k}={v}\n" for k, v in caps.items())
    )


def write(rec: Recording, out: Path, num: int = 5, udev: dict[str, str] | None = None) -> MockFiles:
    """Write the three files for `rec` as /dev/input/event<num> into directory `out`."""
    node = f"/dev/input/event{num}"
    stem = out / f"event{num}"
    files = MockFiles(
        node,
        stem.with_suffix(".umockdev"),
        stem.with_suffix(".ioctl"),
        stem.with_suffix(".events"),
        f"/sys/devices/virtual/input/input{num}/event{num}",
        f"/sys/devices/virtual/input/input{num}",
    )
    files.umockdev.write_text(umockdev_text(rec.description, num, udev or {}))
    files.ioctl.write_text(ioctl_text(rec.description, node))
    files.events.write_text(write_events(rec.events))
    return files
