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
import sys
from dataclasses import dataclass
from pathlib import Path

from stiction.drivers.evdev.description import DeviceDescription

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evdev"))
from evdev_mockfiles import ioctl_text, umockdev_text

HIDRAW_MAJOR = 243
HID_MAX_DESCRIPTOR_SIZE = 4096


@dataclass(frozen=True)
class Node:
    """One mocked device: its /dev node and the files describing it."""

    dev: str
    umockdev: Path
    ioctl: Path
    usb_dev: str | None = None  # the USB device node above a hidraw node


def evdev_node(
    desc: DeviceDescription, num: int, out: Path, udev: dict[str, str], id_input: bool = True
) -> Node:
    """/dev/input/event<num> with `desc`'s identity, capabilities and absinfo.

    The files are the evdev tests' own (evdev_mockfiles); `udev` and (with
    `id_input`) ID_INPUT=1 go into the mocked udev database, without them
    udev's input_id builtin classifies the device.
    """
    dev = f"/dev/input/event{num}"
    ioctl = out / f"event{num}.ioctl"
    ioctl.write_text(ioctl_text(desc, dev))
    umockdev = out / f"event{num}.umockdev"
    umockdev.write_text(umockdev_text(desc, num, udev, id_input=id_input))
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
