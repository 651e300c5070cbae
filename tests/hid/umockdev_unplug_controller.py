"""Runs under the system python3 (GI): builds a umockdev testbed, unplugs mid-stream.

Usage: /usr/bin/python3 umockdev_unplug_controller.py DEVICE.umockdev IOCTL SCRIPT NODE -- CMD...
Starts CMD (the hidraw reader) inside the testbed, waits for its
{"reached": N} line, then hangs up the node's pty as a vanished device does
(the reader's poll() sees POLLHUP and hidapi's read fails), and relays the
reader's output and exit status.
"""

import json
import os
import subprocess
import sys

import gi

gi.require_version("UMockdev", "1.0")
from gi.repository import UMockdev  # noqa: E402


def main() -> int:
    sep = sys.argv.index("--")
    device, ioctl, script, node = sys.argv[1:sep]
    cmd = sys.argv[sep + 1 :]
    tb = UMockdev.Testbed.new()
    tb.add_from_file(device)
    tb.load_ioctl(node, ioctl)
    tb.load_script(node, script)
    env = dict(os.environ)
    env["UMOCKDEV_DIR"] = tb.get_root_dir()
    env["LD_PRELOAD"] = "libumockdev-preload.so.0"
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, env=env, text=True)
    assert proc.stdout is not None
    lines = []
    unplugged = False
    for line in proc.stdout:
        lines.append(line)
        if not unplugged and line.startswith("{") and "reached" in json.loads(line):
            os.close(tb.get_dev_fd(node))  # the device goes away
            unplugged = True
    status = proc.wait(timeout=30)
    sys.stdout.write("".join(lines))
    print(json.dumps({"controller_unplugged": unplugged}))
    del tb
    return status


if __name__ == "__main__":
    sys.exit(main())
