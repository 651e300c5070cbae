"""Generate umockdev files for a mocked /dev/hidrawN from a descriptor and reports.

The three files (see shared/design/testing.md and umockdev's
script-format.txt): a `.umockdev` sysfs/udev description (hidraw node ->
hid device with HID_ID/HID_NAME/report_descriptor -> USB interface -> USB
device), an `.ioctl` file answering HIDIOCGRDESCSIZE/HIDIOCGRDESC, and a
`.script` file with one `r` (read) line per report, after any `w` (write)
lines the program must send first (umockdev replays the script in order).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

HIDRAW_MAJOR = 243
NODE = 5
HID_MAX_DESCRIPTOR_SIZE = 4096


@dataclass(frozen=True)
class MockFiles:
    device: Path
    ioctl: Path
    script: Path
    dev_node: str


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
) -> MockFiles:
    node = f"hidraw{NODE}"
    usb_dev = "/devices/pci0000:00/0000:00:14.0/usb1/1-3"
    usb_if = f"{usb_dev}/1-3:1.{interface}"
    hid = f"{usb_if}/0003:{vid:04X}:{pid:04X}.0001"
    hidraw = f"{hid}/hidraw/{node}"
    text = f"""P: {hidraw}
N: {node}
E: DEVNAME=/dev/{node}
E: MAJOR={HIDRAW_MAJOR}
E: MINOR={NODE}
E: SUBSYSTEM=hidraw
A: dev={HIDRAW_MAJOR}:{NODE}
L: device=../../../0003:{vid:04X}:{pid:04X}.0001

P: {hid}
E: DRIVER=hid-generic
E: HID_ID=0003:0000{vid:04X}:0000{pid:04X}
E: HID_NAME={name}
E: HID_PHYS=usb-0000:00:14.0-3/input{interface}
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
N: bus/usb/001/004
E: DEVNAME=/dev/bus/usb/001/004
E: DEVTYPE=usb_device
E: DRIVER=usb
E: PRODUCT={vid:x}/{pid:x}/100
E: SUBSYSTEM=usb
E: BUSNUM=001
E: DEVNUM=004
A: busnum=1
A: devnum=4
A: idVendor={vid:04x}
A: idProduct={pid:04x}
A: bcdDevice=0100
A: manufacturer=stiction test
A: product={name}
A: serial=
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
    return MockFiles(device, ioctl, script, f"/dev/{node}")
