"""The fault benchmark's device storm: a pen tablet plugged in and out under umockdev.

There is no /dev/uinput in a container and a synthetic pen cannot vanish, so
the storm mocks the kernel side instead: _storm_controller.py (system python3
with umockdev's GI bindings) adds an evdev node with an "add" uevent, plays
a stroke on it, and unplugs it mid-stroke with a "remove" uevent and ENODEV
on every read, then plugs in the next one. The daemon runs with umockdev's
preload library and the testbed's UMOCKDEV_DIR, so what it exercises is its
production path: its pyudev monitor, python-evdev reads, the closing "up" of
a vanished device and the reopen by name.
"""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
from pathlib import Path
from typing import Any

from evdev import ecodes

from stiction.bench._umockdev_evdev import write
from stiction.drivers.evdev.description import AbsAxis, DeviceDescription
from stiction.drivers.evdev.recording import Recording

STORM_NAME = "stiction storm pen"
FIRST_NODE = 5
CYCLE_MIN_S = 0.35  # _storm_controller's shortest hold + gap
CONTROLLER = Path(__file__).with_name("_storm_controller.py")
SYSTEM_PYTHON = "/usr/bin/python3"


def storm_problem() -> str | None:
    """Why the storm cannot run on this machine, or None."""
    if shutil.which("umockdev-wrapper") is None or not Path(SYSTEM_PYTHON).exists():
        return "needs umockdev-wrapper and /usr/bin/python3 (Debian: umockdev)"
    probe = "import gi; gi.require_version('UMockdev', '1.0'); from gi.repository import UMockdev"
    r = subprocess.run([SYSTEM_PYTHON, "-c", probe], capture_output=True, check=False)
    if r.returncode != 0:
        return "needs umockdev's GI bindings (Debian: python3-gi gir1.2-umockdev-1.0)"
    return None


def storm_pen(frames: int = 20) -> Recording:
    """A pen with a 200 x 150 mm surface drawing a line at 100 Hz, still down at the end."""
    res = 100  # units/mm
    desc = DeviceDescription(
        name=STORM_NAME,
        bustype=0x03,
        vendor=0x1D6B,  # the Linux Foundation's id, as virtual devices use
        product=0x5354,
        version=1,
        properties=frozenset({ecodes.INPUT_PROP_DIRECT}),
        keys=frozenset({ecodes.BTN_TOUCH, ecodes.BTN_TOOL_PEN, ecodes.BTN_STYLUS}),
        axes={
            ecodes.ABS_X: AbsAxis(0, 0, 200 * res, resolution=res),
            ecodes.ABS_Y: AbsAxis(0, 0, 150 * res, resolution=res),
            ecodes.ABS_PRESSURE: AbsAxis(0, 0, 4095),
        },
        udev={"ID_INPUT_TABLET": "1"},
    )
    events: list[tuple[int, int, int, int, int]] = []
    for i in range(frames):
        sec, usec = 1000 + i // 100, (i % 100) * 10_000
        if i == 0:
            events += [(sec, usec, ecodes.EV_KEY, ecodes.BTN_TOOL_PEN, 1),
                       (sec, usec, ecodes.EV_KEY, ecodes.BTN_TOUCH, 1)]  # fmt: skip
        events += [
            (sec, usec, ecodes.EV_ABS, ecodes.ABS_X, 5000 + 150 * i),
            (sec, usec, ecodes.EV_ABS, ecodes.ABS_Y, 7500),
            (sec, usec, ecodes.EV_ABS, ecodes.ABS_PRESSURE, 2000),
            (sec, usec, ecodes.EV_SYN, ecodes.SYN_REPORT, 0),
        ]
    return Recording(desc, events, Path(STORM_NAME), Path(STORM_NAME))


class DeviceStorm:
    """The controller process; the daemon is started by the caller with `daemon_env()`."""

    def __init__(self, tmp: Path, seconds: float, seed: int) -> None:
        self.dir = tmp / "storm"
        self.dir.mkdir()
        count = int(seconds / CYCLE_MIN_S) + 2
        pen = storm_pen()
        for num in range(FIRST_NODE, FIRST_NODE + count):
            write(pen, self.dir, num=num, udev=pen.description.udev)
        self.log = (tmp / "storm-controller.log").open("w")
        self.proc = subprocess.Popen(
            ["umockdev-wrapper", SYSTEM_PYTHON, str(CONTROLLER), str(self.dir),
             str(FIRST_NODE), str(count), str(seed)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.log, text=True,
        )  # fmt: skip
        self.root = str(self._line(30.0)["root"])

    def _line(self, timeout: float) -> dict[str, Any]:
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line:
            raise RuntimeError(f"the umockdev storm controller is silent (see {self.log.name})")
        return dict(json.loads(line))

    def _send(self, word: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(word + "\n")
        self.proc.stdin.flush()

    def daemon_env(self) -> dict[str, str]:
        preload = "libumockdev-preload.so.0"
        if os.environ.get("LD_PRELOAD"):
            preload += ":" + os.environ["LD_PRELOAD"]
        return dict(os.environ, LD_PRELOAD=preload, UMOCKDEV_DIR=self.root)

    def go(self) -> None:
        self._send("go")

    def stop(self) -> dict[str, Any]:
        """Stop plugging; the last node is left unplugged. Returns plugs, unplugs, error."""
        self._send("stop")
        return self._line(30.0)

    def close(self) -> None:
        """After the daemon has exited: the controller removes the testbed."""
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.log.close()
