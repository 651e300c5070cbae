"""umockdev description files for the doctor tests (test helper).

Written after shared/design/umockdev-evdev.md and testing.md: an evdev node
needs a `.umockdev` sysfs/udev description and an `.ioctl` file answering
exactly the requests python-evdev 2.0.0 sends (umockdev matches the buffer
size too); a hidraw node needs the sysfs chain hidraw -> hid (with its
report_descriptor) -> USB interface -> USB device, and HIDIOCGRDESC answers.
Only what opening a device needs is generated: the doctor reads no events.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

from stiction.drivers.evdev.description import EV_ABS, EV_KEY, EV_SYN, DeviceDescription

HIDRAW_MAJOR = 243
HID_MAX_DESCRIPTOR_SIZE = 4096


@dataclass(frozen=True)
class Node:
    """One mocked device: its /dev node and the files describing it."""

    dev: str
    umockdev: Path
    ioctl: Path
    usb_dev: str | None = None  # the USB device node above a hidraw node


def _mask(bits: frozenset[int] | set[int], size: int) -> bytes:
    out = bytearray(size)
    for b in bits:
        if b // 8 < size:
            out[b // 8] |= 1 << (b % 8)
    return bytes(out)


def _sysfs_mask(bits: frozenset[int] | set[int]) -> str:
    if not bits:
        return "0"
    words = [0] * (max(bits) // 64 + 1)
    for b in bits:
        words[b // 64] |= 1 << (b % 64)
    return " ".join(f"{w:x}" for w in reversed(words))


def _types(desc: DeviceDescription) -> set[int]:
    types = {EV_SYN}
    if desc.keys:
        types.add(EV_KEY)
    if desc.axes:
        types.add(EV_ABS)
    types.update(t for t, codes in desc.other.items() if codes)
    return types


def _codes(desc: DeviceDescription, t: int) -> frozenset[int]:
    if t == EV_KEY:
        return desc.keys
    if t == EV_ABS:
        return frozenset(desc.axes)
    return desc.other.get(t, frozenset())


def evdev_node(
    desc: DeviceDescription, num: int, out: Path, udev: dict[str, str], id_input: bool = True
) -> Node:
    """/dev/input/event<num> with `desc`'s identity, capabilities and absinfo.

    `udev` and (with `id_input`) ID_INPUT=1 go into the mocked udev database;
    without them udev's own input_id builtin classifies the device.
    """
    dev = f"/dev/input/event{num}"
    name = desc.name.encode()[:255]
    types = _types(desc)
    lines = [
        f"@DEV {dev}",
        "EVIOCGID 0 "
        + struct.pack("<4H", desc.bustype, desc.vendor, desc.product, desc.version).hex(),
        "EVIOCGVERSION 0 " + struct.pack("<i", 0x010001).hex(),
        f"EVIOCGNAME(0) {len(name) + 1} " + name.ljust(256, b"\0").hex(),
        "EVIOCGBIT(0) 4 " + _mask(types, 4).hex(),
        "EVIOCGBIT(0) 8 " + _mask(types, 96).hex(),
    ]
    for t in sorted(types - {EV_SYN}):
        lines.append(
            f"EVIOCGBIT({t}) {96 if t == EV_KEY else 8} " + _mask(_codes(desc, t), 96).hex()
        )
    for code, a in sorted(desc.axes.items()):
        absinfo = struct.pack(
            "<6i", a.value, a.minimum, a.maximum, a.fuzz, a.flat, int(a.resolution)
        )
        lines.append(f"EVIOCGABS({code}) 0 " + absinfo.hex())
    lines += [
        "EVIOCGPROP(0) 4 " + _mask(desc.properties, 4).hex(),
        "EVIOCGKEY(0) 96 " + bytes(96).hex(),
        "EVIOCGLED(0) 2 0000",
        "EVIOCGEFFECTS 0 00000000",
    ]
    ioctl = out / f"event{num}.ioctl"
    ioctl.write_text("\n".join(lines) + "\n")
    minor = 64 + num
    props = "".join(f"E: {k}={v}\n" for k, v in udev.items())
    id_line = "E: ID_INPUT=1\n" if id_input else ""
    caps = {
        "ev": _sysfs_mask(types),
        "key": _sysfs_mask(desc.keys),
        "abs": _sysfs_mask(frozenset(desc.axes)),
        "msc": _sysfs_mask(desc.other.get(4, frozenset())),
        "rel": _sysfs_mask(desc.other.get(2, frozenset())),
    }
    text = (
        f"P: /devices/virtual/input/input{num}/event{num}\n"
        f"N: input/event{num}\n"
        f"E: DEVNAME={dev}\n{id_line}{props}"
        f"E: MAJOR=13\nE: MINOR={minor}\nE: SUBSYSTEM=input\n"
        f"A: dev=13:{minor}\n"
        f"L: device=../../input{num}\n\n"
        f"P: /devices/virtual/input/input{num}\n"
        f'E: NAME="{desc.name}"\n'
        f"E: PRODUCT={desc.bustype:x}/{desc.vendor:x}/{desc.product:x}/{desc.version:x}\n"
        f"E: SUBSYSTEM=input\n{id_line}{props}"
        f"A: name={desc.name}\n"
        f"A: properties={_sysfs_mask(desc.properties)}\n"
        f"A: id/bustype={desc.bustype:04x}\nA: id/vendor={desc.vendor:04x}\n"
        f"A: id/product={desc.product:04x}\nA: id/version={desc.version:04x}\n"
        + "".join(f"A: capabilities/{k}={v}\n" for k, v in caps.items())
    )
    umockdev = out / f"event{num}.umockdev"
    umockdev.write_text(text)
    return Node(dev, umockdev, ioctl)


def _usb_descriptors(vid: int, pid: int, report_len: int) -> bytes:
    """sysfs `descriptors`: device then configuration descriptor, as libusb reads them."""
    device = struct.pack(
        "<BBHBBBBHHHBBBB", 18, 1, 0x0200, 0, 0, 0, 64, vid, pid, 0x0100, 1, 2, 0, 1
    )
    interface = bytes([9, 4, 0, 0, 1, 3, 0, 0, 0])
    hid = struct.pack("<BBHBBBH", 9, 0x21, 0x0111, 0, 1, 0x22, report_len)
    endpoint = bytes([7, 5, 0x81, 3, 64, 0, 1])
    body = interface + hid + endpoint
    config = struct.pack("<BBHBBBBB", 9, 2, 9 + len(body), 1, 1, 0, 0x80, 50)
    return device + config + body


def hidraw_node(name: str, vid: int, pid: int, descriptor: bytes, num: int, out: Path) -> Node:
    """/dev/hidraw<num> on its own USB device (bus 1, device num + 10, port num)."""
    node = f"hidraw{num}"
    devnum = num + 10
    usb_dev = f"/devices/pci0000:00/0000:00:14.0/usb1/1-{num}"
    usb_if = f"{usb_dev}/1-{num}:1.0"
    hid_name = f"0003:{vid:04X}:{pid:04X}.{num:04X}"
    hid = f"{usb_if}/{hid_name}"
    usb_node = f"bus/usb/001/{devnum:03d}"
    text = f"""P: {hid}/hidraw/{node}
N: {node}
E: DEVNAME=/dev/{node}
E: MAJOR={HIDRAW_MAJOR}
E: MINOR={num}
E: SUBSYSTEM=hidraw
A: dev={HIDRAW_MAJOR}:{num}
L: device=../../../{hid_name}

P: {hid}
E: DRIVER=hid-generic
E: HID_ID=0003:0000{vid:04X}:0000{pid:04X}
E: HID_NAME={name}
E: HID_PHYS=usb-0000:00:14.0-{num}/input0
E: HID_UNIQ=
E: MODALIAS=hid:b0003g0001v0000{vid:04X}p0000{pid:04X}
E: SUBSYSTEM=hid
H: report_descriptor={descriptor.hex().upper()}

P: {usb_if}
E: DEVTYPE=usb_interface
E: DRIVER=usbhid
E: INTERFACE=3/0/0
E: SUBSYSTEM=usb
A: bInterfaceClass=03
A: bInterfaceNumber=00
A: bInterfaceProtocol=00
A: bInterfaceSubClass=00

P: {usb_dev}
N: {usb_node}
E: DEVNAME=/dev/{usb_node}
E: DEVTYPE=usb_device
E: DRIVER=usb
E: MAJOR=189
E: MINOR={devnum - 1}
E: PRODUCT={vid:x}/{pid:x}/100
E: SUBSYSTEM=usb
E: BUSNUM=001
E: DEVNUM={devnum:03d}
A: busnum=1
A: devnum={devnum}
A: dev=189:{devnum - 1}
A: idVendor={vid:04x}
A: idProduct={pid:04x}
A: bcdDevice=0100
A: manufacturer=stiction test
A: product={name}
A: serial=
H: descriptors={_usb_descriptors(vid, pid, len(descriptor)).hex().upper()}
"""
    umockdev = out / f"{node}.umockdev"
    umockdev.write_text(text)
    size = len(descriptor)
    buf = size.to_bytes(4, "little") + descriptor.ljust(HID_MAX_DESCRIPTOR_SIZE, b"\0")
    ioctl = out / f"{node}.ioctl"
    ioctl.write_text(
        f"@DEV /dev/{node}\n"
        f"HIDIOCGRDESCSIZE 0 {size.to_bytes(4, 'little').hex().upper()}\n"
        f"HIDIOCGRDESC 0 {buf.hex().upper()}\n"
    )
    return Node(f"/dev/{node}", umockdev, ioctl, f"/dev/{usb_node}")
