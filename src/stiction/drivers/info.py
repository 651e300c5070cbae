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
    """

    path: str
    backend: str
    vid: int
    pid: int
    name: str
    kind: str
    problem: str | None = None

    @property
    def vid_pid(self) -> str:
        return f"{self.vid:04x}:{self.pid:04x}"
