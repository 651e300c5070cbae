"""umockdev GI controller for `stiction bench faults`: a tablet plugged in and out, again and again.

Runs in the system python3 (the only one with `gi`) under umockdev-wrapper;
imports only the standard library, gi and _umockdev_ioctl beside it. The
benchmark starts the daemon itself with the testbed's UMOCKDEV_DIR, so the
daemon sees the storm through its own pyudev monitor and python-evdev reads,
as on a real machine: an "add" uevent with the node, then recorded events,
then a "remove" uevent with every read and ioctl failing ENODEV (the kernel's
answer for a vanished device, shared/design/umockdev-evdev.md section 6).

usage: _storm_controller.py DIR FIRST COUNT SEED
DIR holds eventN.{umockdev,ioctl,events} for N in FIRST..FIRST+COUNT-1 (umockdev
0.17 cannot re-create a removed node name, and a replugged device gets a new
event number from the kernel anyway). Protocol on stdin/stdout, one line each:
prints {"root": DIR}; waits for "go"; storms until "stop" (or the nodes run
out); prints {"plugs": n, "unplugs": n, "error": null|text}; exits at EOF.
"""

from __future__ import annotations

import errno
import json
import os
import random
import struct
import sys
import threading
import time

import gi

gi.require_version("UMockdev", "1.0")
from gi.repository import UMockdev  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _umockdev_ioctl import answer_from_table, load_table  # type: ignore[import-not-found]  # noqa: E402

HOLD_S = (0.1, 0.4)  # plugged in after the stroke was written
GAP_S = (0.05, 0.3)  # unplugged
INPUT_EVENT = struct.Struct("llHHi")  # struct input_event on a 64-bit kernel


class Handler(UMockdev.IoctlBase):  # type: ignore[misc]
    def __init__(self, table: dict[int, tuple[int, bytes]]) -> None:
        super().__init__()
        self.table = table
        self.unplugged = threading.Event()

    def do_handle_ioctl(self, client):  # type: ignore[no-untyped-def]
        if self.unplugged.is_set():
            client.complete(-1, errno.ENODEV)
            return True
        return answer_from_table(self.table, client.get_request(), client)

    def do_handle_read(self, client):  # type: ignore[no-untyped-def]
        if self.unplugged.is_set():
            client.complete(-1, errno.ENODEV)
            return True
        return False


def play(fd: int, path: str, stop: threading.Event) -> None:
    """Write the node's evemu events at their recorded pace, stamped now, as the kernel would.

    Written here rather than by umockdev's evemu runner: the runner writes from
    a thread of its own, and a pty hung up under it aborts the controller
    ("write failed: Bad file descriptor"); an unplug must come at any moment.
    """
    prev = None
    with open(path) as f:
        for line in f:
            if not line.startswith("E: "):
                continue
            stamp, etype, code, value = line[3:].split()
            sec, usec = stamp.split(".")
            t = int(sec) + int(usec) / 1e6
            if prev is not None and t > prev and stop.wait(t - prev):
                return
            prev = t
            now = time.time()
            os.write(fd, INPUT_EVENT.pack(int(now), int(now % 1 * 1e6), int(etype, 16),
                                          int(code, 16), int(value)))  # fmt: skip


def _say(obj: object) -> None:
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()


def storm(tb: object, d: str, first: int, count: int, rng: random.Random,
          stop: threading.Event) -> tuple[int, int]:  # fmt: skip
    plugs = unplugs = 0
    ptymap = os.path.join(tb.get_root_dir(), "dev", ".ptymap")  # type: ignore[attr-defined]
    for num in range(first, first + count):
        if stop.is_set():
            break
        node = f"/dev/input/event{num}"
        sys_input = f"/sys/devices/virtual/input/input{num}"
        sys_event = f"{sys_input}/event{num}"
        # umockdev 0.17 leaves dev/.ptymap/_dev_pts_N behind after a removal; the
        # next node gets the freed pty number and would abort on the stale link.
        for entry in os.listdir(ptymap) if os.path.isdir(ptymap) else ():
            os.unlink(os.path.join(ptymap, entry))
        handler = Handler(load_table(os.path.join(d, f"event{num}.ioctl")))
        tb.attach_ioctl(node, handler)  # type: ignore[attr-defined]
        tb.add_from_file(os.path.join(d, f"event{num}.umockdev"))  # type: ignore[attr-defined]
        plugs += 1
        fd = tb.get_dev_fd(node)  # type: ignore[attr-defined]
        play(fd, os.path.join(d, f"event{num}.events"), stop)
        stop.wait(rng.uniform(*HOLD_S))
        handler.unplugged.set()
        tb.uevent(sys_event, "remove")  # type: ignore[attr-defined]
        tb.remove_device(sys_event)  # type: ignore[attr-defined]
        tb.remove_device(sys_input)  # type: ignore[attr-defined]
        os.close(fd)  # hang up the pty: a reader blocked in select() wakes to ENODEV
        unplugs += 1
        stop.wait(rng.uniform(*GAP_S))
    return plugs, unplugs


def main() -> int:
    d, first, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    tb = UMockdev.Testbed.new()
    go, stop, eof = threading.Event(), threading.Event(), threading.Event()

    def commands() -> None:
        for line in sys.stdin:
            if line.strip() == "go":
                go.set()
            elif line.strip() == "stop":
                stop.set()
        go.set()
        stop.set()
        eof.set()

    threading.Thread(target=commands, daemon=True).start()
    _say({"root": tb.get_root_dir()})
    go.wait()
    plugs = unplugs = 0
    error = None
    try:
        plugs, unplugs = storm(tb, d, first, count, random.Random(seed), stop)
    except Exception as exc:  # reported to the benchmark, which counts it as a failure
        error = f"{type(exc).__name__}: {exc}"
    _say({"plugs": plugs, "unplugs": unplugs, "error": error})
    eof.wait()  # keep the testbed until the benchmark has stopped the daemon
    del tb
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
