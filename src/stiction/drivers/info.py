"""What discovery says about a device, before anything opens it for reading."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class DeviceInfo:
    """A candidate input device found on this machine.

    `backend` is what would read it ("hidraw" or "evdev"); `kind` is "pen",
    "touchpad", "touchscreen", "other", or "unknown" for a node that could not
    be probed at all. `problem` is None when stiction can open the node, else
    one sentence saying why not and what to do.

    The last fields are filled by stiction.drivers.discovery, which sees both
    backends at once (a backend's own ``discover()`` leaves them None):
    `hid_device` is the sysfs path of the HID device the node belongs to (a
    tablet's hidraw node and its event nodes share it), `sized` whether this
    backend knows the surface's physical size (None: could not tell),
    `size_from` where from ("kernel" resolution or evdev size "table"; HID
    "descriptor" or "vendor-init"), `chosen` whether this node is the one
    that reads its device when nothing asks for a backend, and `reason` why
    (or why the other node is read).
    """

    path: str
    backend: str
    vid: int
    pid: int
    name: str
    kind: str
    problem: str | None = None
    hid_device: str | None = None
    sized: bool | None = None
    size_from: str | None = None
    chosen: bool | None = None
    reason: str | None = None

    @property
    def vid_pid(self) -> str:
        return f"{self.vid:04x}:{self.pid:04x}"
