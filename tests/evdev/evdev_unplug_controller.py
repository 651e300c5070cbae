"""umockdev GI controller: a mocked evdev node that is unplugged and plugged back (test helper).

Runs under the system python3 (the only one with `gi`), itself under
umockdev-wrapper so that uevents reach the mocked udev. It answers the
reader's ioctls from the generated .ioctl file, and after the unplug fails
every read with ENODEV, as the kernel does for a vanished device
(shared/design/umockdev-evdev.md section 6). The reader is stiction's own
driver in a subprocess; this script only reports what it printed.

usage: evdev_unplug_controller.py DIR READER_PYTHON READER_SCRIPT UNPLUG_AFTER [crash]
prints one JSON object: {"reader": [lines...], "returncode": int, "grabs": [EVIOCGRAB args]}
With `crash` or `run`, nothing is unplugged: the reader is expected to end on its own.
A state.json in DIR answers EVIOCGKEY, EVIOCGMTSLOTS and EVIOCGABS(ABS_MT_SLOT):
the device state a reader re-reads after SYN_DROPPED.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import select
import subprocess
import sys
import threading

import gi

gi.require_version("UMockdev", "1.0")
from gi.repository import UMockdev  # noqa: E402

# The table reader is shared with the fault benchmark's device storm; it lives in
# the package but imports only the standard library, so load it by path.
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "src", "stiction", "bench"))
from _umockdev_ioctl import EVIOCGRAB, answer_from_table, load_table  # noqa: E402

__all__ = ["EVIOCGRAB", "answer_from_table", "load_table"]


class Handler(UMockdev.IoctlBase):
    def __init__(self, table: dict[int, tuple[int, bytes]]) -> None:
        super().__init__()
        self.table = table
        self.unplugged = threading.Event()
        self.grabs: list[int] = []  # EVIOCGRAB arguments in order: 1 grab, 0 release
        #: the device state answered after SYN_DROPPED: {"keys", "slot", "slots"}
        self.state: dict | None = None  # type: ignore[type-arg]

    def do_handle_ioctl(self, client):  # type: ignore[no-untyped-def]
        if self.unplugged.is_set():
            client.complete(-1, errno.ENODEV)
            return True
        req = client.get_request()
        if req == EVIOCGRAB:
            arg = client.get_arg()
            self.grabs.append(int.from_bytes(bytes(arg.data or b"")[:8], "little"))
            client.complete(0, 0)
            return True
        if self.state is not None and (req >> 8) & 0xFF == ord("E"):
            nr, size = req & 0xFF, (req >> 16) & 0x3FFF
            if nr == 0x0A:  # EVIOCGMTSLOTS: {u32 code; s32 values[]}, the code is input
                data = client.get_arg().resolve(0, size)
                code = int.from_bytes(bytes(data.data)[:4], "little")
                values = self.state["slots"].get(str(code))
                if values is None:
                    client.complete(-1, errno.EINVAL)
                    return True
                n = (size - 4) // 4
                vals = (values + [0] * n)[:n]
                payload = code.to_bytes(4, "little") + b"".join(
                    v.to_bytes(4, "little", signed=True) for v in vals
                )
                data.update(0, payload)
                client.complete(0, 0)
                return True
            if nr == 0x18:  # EVIOCGKEY: the keys down at the moment of the re-read
                mask = bytearray(size)
                for k in self.state["keys"]:
                    mask[k // 8] |= 1 << (k % 8)
                client.get_arg().resolve(0, size).update(0, bytes(mask))
                client.complete(size, 0)
                return True
            if nr == 0x40 + 0x2F:  # EVIOCGABS(ABS_MT_SLOT): the current slot
                info = self.state["slot"].to_bytes(4, "little") + self.table[req][1][4:]
                client.get_arg().resolve(0, len(info)).update(0, info)
                client.complete(0, 0)
                return True
        return answer_from_table(self.table, req, client)

    def do_handle_read(self, client):  # type: ignore[no-untyped-def]
        if self.unplugged.is_set():
            client.complete(-1, errno.ENODEV)
            return True
        return False


class _Done(Exception):
    pass


def main() -> int:
    d, reader_py, reader_script, unplug_after = sys.argv[1:5]
    mode = sys.argv[5] if len(sys.argv) > 5 else "unplug"
    node = "/dev/input/event5"
    sys_event = "/sys/devices/virtual/input/input5/event5"
    sys_input = "/sys/devices/virtual/input/input5"
    tb = UMockdev.Testbed.new()
    tb.add_from_file(os.path.join(d, "event5.umockdev"))
    handler = Handler(load_table(os.path.join(d, "event5.ioctl")))
    state_file = os.path.join(d, "state.json")
    if os.path.exists(state_file):
        with open(state_file) as f:
            handler.state = json.load(f)
    tb.attach_ioctl(node, handler)
    env = dict(os.environ, UMOCKDEV_DIR=tb.get_root_dir())
    proc = subprocess.Popen(
        [reader_py, "-c", reader_script, node],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        text=True,
    )
    lines: list[str] = []
    pending: list[str] = []
    buf = b""
    out_fd = proc.stdout.fileno()  # type: ignore[union-attr]

    def next_line(timeout: float = 20.0) -> str:
        # Raw reads: a buffered readline() could swallow several lines at once and
        # leave select() waiting for data that has already arrived.
        nonlocal buf
        while not pending:
            ready, _, _ = select.select([out_fd], [], [], timeout)
            if not ready:
                raise TimeoutError(f"reader silent; so far {lines}")
            chunk = os.read(out_fd, 65536)
            if not chunk:
                raise TimeoutError(f"reader exited; so far {lines}")
            buf += chunk
            *done, buf = buf.split(b"\n")
            pending.extend(x.decode() for x in done)
        line = pending.pop(0)
        lines.append(line)
        return line

    try:
        assert next_line() == "ready", lines
        tb.load_evemu_events(node, os.path.join(d, "event5.events"))
        if mode in ("crash", "run"):  # the reader ends by itself; only watch it
            raise TimeoutError("crash mode") if proc.wait(timeout=30) is None else _Done()
        samples = 0
        while samples < int(unplug_after):
            if next_line().startswith("["):
                samples += 1
        # every event has been read, so the evemu runner wrote its last one: the pty
        # can be hung up without it writing into a closed fd
        handler.unplugged.set()
        tb.uevent(sys_event, "remove")
        tb.remove_device(sys_event)
        tb.remove_device(sys_input)
        os.close(tb.get_dev_fd(node))  # hang up the pty so a blocked select() wakes
        while not next_line().startswith('{"error"'):
            pass
        assert next_line().startswith('{"reopen_failed"'), lines
        # Plug it back. A replugged device usually gets a new event number from the
        # kernel, and umockdev 0.17 cannot re-create a removed node name in one
        # testbed anyway, so it returns as event6 (files written by the test).
        replug = "/dev/input/event6"
        # umockdev 0.17 also leaves dev/.ptymap/_dev_pts_N behind; the new node gets
        # the freed pty number and would abort on the stale link.
        ptymap = os.path.join(tb.get_root_dir(), "dev", ".ptymap")
        for entry in os.listdir(ptymap) if os.path.isdir(ptymap) else ():
            os.unlink(os.path.join(ptymap, entry))
        tb.attach_ioctl(replug, Handler(load_table(os.path.join(d, "event6.ioctl"))))
        tb.add_from_file(os.path.join(d, "event6.umockdev"))
        proc.stdin.write("replugged\n")  # type: ignore[union-attr]
        proc.stdin.flush()  # type: ignore[union-attr]
        next_line()
    except _Done:
        pass
    except (TimeoutError, AssertionError, subprocess.TimeoutExpired) as exc:
        lines.append(f"controller: {exc}")
    finally:
        with contextlib.suppress(OSError):
            proc.stdin.close()  # type: ignore[union-attr]
        proc.stdin = None
        try:
            out, err = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
        lines.extend(pending)
        lines.extend(x for x in (buf.decode() + out).splitlines() if x)
        print(
            json.dumps(
                {
                    "reader": lines,
                    "stderr": err,
                    "returncode": proc.returncode,
                    "grabs": handler.grabs,
                }
            )
        )
        del tb
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
