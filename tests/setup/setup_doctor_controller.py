"""umockdev GI controller for the doctor tests (test helper; runs under the system python3).

usage: setup_doctor_controller.py SPEC.json
SPEC: {"devices": [.umockdev files], "ioctl": {node: .ioctl file},
       "busy": {node: .ioctl file}, "deny": [nodes], "argv": [...]}

Builds one testbed with every device, then runs `argv` (the real `stiction
doctor`) with umockdev's preload library pointing at it. Three things the
command-line umockdev-run cannot do, done the way a real system would show
them to the program:

- "busy" nodes answer their ioctls from the .ioctl table through a Python
  handler that fails EVIOCGRAB with EBUSY, as the kernel does when another
  client holds the grab (umockdev's built-in EVIOCGRAB always succeeds);
- "deny" nodes get mode 000 on the pty behind them, so open() fails with
  EACCES in the kernel's own permission check (the test runs the doctor
  without CAP_DAC_OVERRIDE when it is root, see the test module);
- the preload is set up here, not by a wrapper, so nothing else changes.

Prints one JSON object: {"returncode", "stdout", "stderr"}.
"""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys

import gi

gi.require_version("UMockdev", "1.0")
from gi.repository import UMockdev  # noqa: E402

# the .ioctl tables are the evdev tests' own (evdev_mockfiles), read by their controller
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "evdev"))
from evdev_unplug_controller import EVIOCGRAB, answer_from_table, load_table  # noqa: E402


class GrabbedElsewhere(UMockdev.IoctlBase):
    """An evdev node another client has grabbed: everything works but EVIOCGRAB."""

    def __init__(self, table: dict[int, tuple[int, bytes]]) -> None:
        super().__init__()
        self.table = table
        self.grab_attempts = 0

    def do_handle_ioctl(self, client):  # type: ignore[no-untyped-def]
        req = client.get_request()
        if req == EVIOCGRAB:
            self.grab_attempts += 1
            client.complete(-1, errno.EBUSY)
            return True
        return answer_from_table(self.table, req, client)

    def do_handle_read(self, client):  # type: ignore[no-untyped-def]
        return False


def main() -> int:
    with open(sys.argv[1]) as f:
        spec = json.load(f)
    tb = UMockdev.Testbed.new()
    handlers = []
    try:
        for dev, path in spec.get("ioctl", {}).items():
            tb.load_ioctl(dev, path)
        for dev, path in spec.get("busy", {}).items():
            handler = GrabbedElsewhere(load_table(path))
            handlers.append(handler)
            tb.attach_ioctl(dev, handler)
        for path in spec["devices"]:
            tb.add_from_file(path)
        root = tb.get_root_dir()
        for dev in spec.get("deny", []):
            os.chmod(os.path.join(root, dev.lstrip("/")), 0)
        preload = " ".join(
            x for x in ("libumockdev-preload.so.0", os.environ.get("LD_PRELOAD")) if x
        )
        env = dict(os.environ, UMOCKDEV_DIR=root, LD_PRELOAD=preload)
        proc = subprocess.run(
            spec["argv"], capture_output=True, text=True, env=env, timeout=60, check=False
        )
        print(
            json.dumps(
                {
                    "returncode": proc.returncode,
                    "stdout": proc.stdout,
                    "stderr": proc.stderr,
                    "grab_attempts": sum(h.grab_attempts for h in handlers),
                }
            )
        )
    finally:
        del tb
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
