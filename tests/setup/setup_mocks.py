"""umockdev description files for the doctor tests (test helper).

Written after shared/design/umockdev-evdev.md and testing.md. The files come
from the builders the evdev and HID tests use themselves (evdev_mockfiles,
umockdev_hidraw); this module only names each device as a Node for the
doctor's controller. The doctor reads no events or reports.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from stiction.drivers.evdev.description import DeviceDescription

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evdev"))
from evdev_mockfiles import ioctl_text, umockdev_text

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "hid"))
from umockdev_hidraw import write_mock


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


def hidraw_node(name: str, vid: int, pid: int, descriptor: bytes, num: int, out: Path) -> Node:
    """/dev/hidraw<num> on its own USB device (bus 1, device num + 10, port num).

    The files are the HID tests' own (umockdev_hidraw), with no reports to
    read: the doctor only opens the node.
    """
    files = write_mock(out, name, vid, pid, descriptor, [], num=num)
    return Node(files.dev_node, files.device, files.ioctl, files.usb_node)
