"""Generate umockdev files for a mocked /dev/hidrawN from a descriptor and reports.

The one hidraw builder of the tests (the HID tests' own; the setup tests use
it too). The three files (see shared/design/testing.md and umockdev's
script-format.txt): a `.umockdev` sysfs/udev description (hidraw node ->
hid device with HID_ID/HID_NAME/report_descriptor -> USB interface -> USB
device with its /dev/bus/usb node and the `descriptors` libusb reads), an
`.ioctl` file answering HIDIOCGRDESCSIZE/HIDIOCGRDESC, and a `.script` file
with one `r` (read) line per report, after any `w` (write) lines the program
must send first (umockdev replays the script in order).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

HIDRAW_MAJOR = 243
USB_MAJOR = 189
NODE = 5
HID_MAX_DESCRIPTOR_SIZE = 4096


@dataclass(frozen=True)
class MockFiles:
    device: Path
    ioctl: Path
    script: Path
    dev_node: str
    usb_node: str  # the /dev/bus/usb node of the USB device above the hidraw node


def _escape(data: bytes) -> bytes:
    out = bytearray()
    for b in data:
        if b == ord("^"):
            out += b"^`"
        elif b < 32:  # 32 (space) is verbatim: "^`" is the escape for "^" itself
            out += bytes((ord("^"), b + 64))
        else:
            out.append(b)
    return bytes(out)


def _usb_descriptors(vid: int, pid: int, interface: int, report_len: int) -> bytes:
    """sysfs `descriptors`: device then configuration descriptor, as libusb reads them."""
    device = struct.pack(
        "<BBHBBBBHHHBBBB", 18, 1, 0x0200, 0, 0, 0, 64, vid, pid, 0x0100, 1, 2, 0, 1
    )
    intf = bytes([9, 4, interface, 0, 1, 3, 0, 0, 0])
    hid = struct.pack("<BBHBBBH", 9, 0x21, 0x0111, 0, 1, 0x22, report_len)
    endpoint = bytes([7, 5, 0x81, 3, 64, 0, 1])
    body = intf + hid + endpoint
    config = struct.pack("<BBHBBBBB", 9, 2, 9 + len(body), 1, 1, 0, 0x80, 50)
    return device + config + body


def write_mock(
    directory: Path,
    name: str,
    vid: int,
    pid: int,
    descriptor: bytes,
    reports: list[bytes],
    delay_ms: int = 1,
    interface: int = 0,
    expect_writes: list[bytes] | None = None,
    num: int = NODE,
) -> MockFiles:
    """/dev/hidraw<num> on its own USB device (bus 1, port num, device num + 10)."""
    node = f"hidraw{num}"
    devnum = num + 10
    usb_dev = f"/devices/pci0000:00/0000:00:14.0/usb1/1-{num}"
    usb_if = f"{usb_dev}/1-{num}:1.{interface}"
    hid_name = f"0003:{vid:04X}:{pid:04X}.{num:04X}"
    hid = f"{usb_if}/{hid_name}"
    usb_node = f"bus/usb/001/{devnum:03d}"
    usb_descriptors = _usb_descriptors(vid, pid, interface, len(descriptor))
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
E: HID_PHYS=usb-0000:00:14.0-{num}/input{interface}
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
A: bInterfaceNumber={interface:02x}
A: bInterfaceProtocol=00
A: bInterfaceSubClass=00

P: {usb_dev}
N: {usb_node}
E: DEVNAME=/dev/{usb_node}
E: DEVTYPE=usb_device
E: DRIVER=usb
E: MAJOR={USB_MAJOR}
E: MINOR={devnum - 1}
E: PRODUCT={vid:x}/{pid:x}/100
E: SUBSYSTEM=usb
E: BUSNUM=001
E: DEVNUM={devnum:03d}
A: busnum=1
A: devnum={devnum}
A: dev={USB_MAJOR}:{devnum - 1}
A: idVendor={vid:04x}
A: idProduct={pid:04x}
A: bcdDevice=0100
A: manufacturer=stiction test
A: product={name}
A: serial=
H: descriptors={usb_descriptors.hex().upper()}
"""
    device = directory / f"{node}.umockdev"
    device.write_text(text)
    size = len(descriptor)
    buf = size.to_bytes(4, "little") + descriptor.ljust(HID_MAX_DESCRIPTOR_SIZE, b"\0")
    ioctl = directory / f"{node}.ioctl"
    ioctl.write_text(
        f"@DEV /dev/{node}\n"
        f"HIDIOCGRDESCSIZE 0 {size.to_bytes(4, 'little').hex().upper()}\n"
        f"HIDIOCGRDESC 0 {buf.hex().upper()}\n"
    )
    script = directory / f"{node}.script"
    with script.open("wb") as fh:
        for data in expect_writes or []:
            fh.write(b"w 0 " + _escape(data) + b"\n")  # the program must write exactly this
        for data in reports:
            fh.write(b"r %d " % delay_ms + _escape(data) + b"\n")
    return MockFiles(device, ioctl, script, f"/dev/{node}", f"/dev/{usb_node}")
