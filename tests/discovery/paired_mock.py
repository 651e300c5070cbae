"""One mocked tablet with both a hidraw node and an evdev node (test helper).

A tablet the kernel drives has both below the same HID device in sysfs:
``<hid>/hidraw/hidrawN`` and ``<hid>/input/inputN/eventN``. The hidraw part
is the HID tests' own builder (umockdev_hidraw: hidraw node, HID device, USB
interface and device); the event node is the evdev tests' (evdev_mockfiles)
moved from /devices/virtual/input to below that HID device, which is how
stiction's discovery pairs the two.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from stiction.drivers.evdev.description import DeviceDescription

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evdev"))
from evdev_mockfiles import ioctl_text, umockdev_text

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "hid"))
from umockdev_hidraw import write_mock


@dataclass(frozen=True)
class PairedMock:
    hidraw: str
    event: str
    files: tuple[Path, ...]  # .umockdev descriptions, parents first
    ioctls: tuple[tuple[str, Path], ...]

    def run(self, argv: list[str], timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
        """Run `argv` with both nodes mocked (umockdev-run)."""
        cmd = ["umockdev-run"]
        for f in self.files:
            cmd += ["--device", str(f)]
        for node, ioctl in self.ioctls:
            cmd += ["--ioctl", f"{node}={ioctl}"]
        return subprocess.run(
            [*cmd, "--", *argv], capture_output=True, text=True, timeout=timeout, check=False
        )


def write_pair(
    out: Path,
    name: str,
    vid: int,
    pid: int,
    descriptor: bytes,
    evdev: DeviceDescription,
    num: int = 5,
) -> PairedMock:
    """/dev/hidraw<num> and /dev/input/event<num> of one USB tablet `vid`:`pid`.

    The event node keeps `evdev`'s capabilities and absinfo (resolution
    included) under the tablet's identity.
    """
    out.mkdir(parents=True, exist_ok=True)
    hid = write_mock(out, name, vid, pid, descriptor, [], num=num)
    # the HID device's sysfs path, as umockdev_hidraw builds it
    hid_dev = (
        f"/devices/pci0000:00/0000:00:14.0/usb1/1-{num}/1-{num}:1.0/"
        f"0003:{vid:04X}:{pid:04X}.{num:04X}"
    )
    desc = dataclasses.replace(evdev, name=f"{name} Pen", bustype=3, vendor=vid, product=pid)
    event = f"/dev/input/event{num}"
    text = umockdev_text(desc, num, {"ID_INPUT_TABLET": "1"})
    text = text.replace("/devices/virtual/input/", f"{hid_dev}/input/")
    umockdev = out / f"event{num}.umockdev"
    umockdev.write_text(text)
    ioctl = out / f"event{num}.ioctl"
    ioctl.write_text(ioctl_text(desc, event))
    return PairedMock(
        hid.dev_node,
        event,
        (hid.device, umockdev),
        ((hid.dev_node, hid.ioctl), (event, ioctl)),
    )
