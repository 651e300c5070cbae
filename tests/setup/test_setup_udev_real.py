"""The generated rules run through systemd's real udev rule engine (`udevadm test`).

`udevadm test` processes every rules file for one device: here the devices
are umockdev-mocked sysfs entries (built from real descriptors and evemu
recordings), so the stock rules run unmodified, including 60-input-id.rules,
whose input_id builtin classifies the evdev nodes from their capability bits,
and 73-seat-late.rules, which runs the uaccess builtin for tagged nodes.

The rules file has to be in a rules directory udev reads, and udevadm test
writes its database under /run/udev. Both happen inside a private mount
namespace on a tmpfs over /run, so the machine is left untouched. That needs
root (as CI runs); elsewhere the test is skipped, the syntactic checks in
test_setup_udev.py still run.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest
from evdev import ecodes
from setup_mocks import Node, evdev_node, hidraw_node

from stiction.drivers.evdev.description import DeviceDescription
from stiction.drivers.evdev.recording import load as load_evdev
from stiction.drivers.hid.recording import load_recording
from stiction.setup.udev_rules import RULES_NAME, builtin_rules

pytestmark = [
    pytest.mark.umockdev,
    pytest.mark.skipif(os.geteuid() != 0, reason="a private tmpfs over /run needs root"),
]

USB = "/sys/devices/pci0000:00/0000:00:14.0/usb1"


def _tools() -> None:
    for tool in ("udevadm", "unshare", "umockdev-run"):
        if shutil.which(tool) is None:
            pytest.fail(f"{tool} is needed for this test (udev, util-linux, umockdev)")


def _udevadm_test(tmp: Path, nodes: list[Node], syspaths: list[str]) -> dict[str, str]:
    """syspath -> what `udevadm test --action=add` printed for it, with our rules installed."""
    rules = tmp / RULES_NAME
    rules.write_text(builtin_rules())
    devices = " ".join(f"-d {shlex.quote(str(n.umockdev))}" for n in nodes)
    script = ["set -e", "mount -t tmpfs stiction-test /run", "mkdir -p /run/udev/rules.d"]
    script.append(f"cp {shlex.quote(str(rules))} /run/udev/rules.d/")
    for i, sp in enumerate(syspaths):
        out = tmp / f"udevadm-{i}.txt"
        script.append(
            f"umockdev-run {devices} -- udevadm test --action=add {shlex.quote(sp)} "
            f"> {shlex.quote(str(out))} 2>&1 || true"
        )
    proc = subprocess.run(
        ["unshare", "--mount", "--propagation", "private", "sh", "-c", "\n".join(script)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    return {sp: (tmp / f"udevadm-{i}.txt").read_text() for i, sp in enumerate(syspaths)}


def _tags(output: str) -> set[str]:
    for line in output.splitlines():
        if line.startswith("TAGS="):
            return {t for t in line[5:].split(":") if t}
    return set()


def _props(output: str) -> set[str]:
    return {line for line in output.splitlines() if line.startswith("ID_INPUT")}


def test_real_udev_tags_exactly_the_tablets(
    tmp_path: Path, hid_data: Path, evdev_data: Path
) -> None:
    _tools()
    huion = load_recording(hid_data / "huion-hs610.hid")  # in the table, USB init
    # an N-trig pen digitizer: in no catalogue entry (built-in digitizers are read
    # through evdev, which input_id tags), so its hidraw node stays untagged
    xp = load_recording(hid_data / "n-trig-1b96-1000-pen.hid")
    pen = load_evdev(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu").description
    pad = load_evdev(evdev_data / "synaptics-touchpad.hp8470p.desc").description
    keyboard = DeviceDescription(
        name="Test Keyboard",
        bustype=3,
        vendor=0x1234,
        product=0x0001,
        keys=frozenset({ecodes.KEY_A, ecodes.KEY_B, ecodes.KEY_ENTER, ecodes.KEY_SPACE}),
    )
    nodes = [
        hidraw_node(huion.name, huion.vid, huion.pid, huion.descriptor, 7, tmp_path),
        hidraw_node(xp.name, xp.vid, xp.pid, xp.descriptor, 6, tmp_path),
        # no udev properties in the database: udev's input_id builtin classifies them
        evdev_node(pen, 5, tmp_path, {}, id_input=False),
        evdev_node(pad, 8, tmp_path, {}, id_input=False),
        evdev_node(keyboard, 9, tmp_path, {}, id_input=False),
    ]
    huion_hidraw = f"{USB}/1-7/1-7:1.0/0003:256C:006D.0007/hidraw/hidraw7"
    huion_usb = f"{USB}/1-7"
    xp_hidraw = f"{USB}/1-6/1-6:1.0/0003:{xp.vid:04X}:{xp.pid:04X}.0006/hidraw/hidraw6"
    xp_usb = f"{USB}/1-6"
    pen_ev, pad_ev, kbd_ev = (f"/sys/devices/virtual/input/input{n}/event{n}" for n in (5, 8, 9))
    out = _udevadm_test(
        tmp_path, nodes, [huion_hidraw, huion_usb, xp_hidraw, xp_usb, pen_ev, pad_ev, kbd_ev]
    )
    for sp in (huion_hidraw, huion_usb, pen_ev, pad_ev):
        assert "uaccess" in _tags(out[sp]), f"{sp}:\n{out[sp]}"
        assert "73-seat-late.rules" in out[sp] and "RUN 'uaccess'" in out[sp], out[sp]
    for sp in (xp_hidraw, xp_usb, kbd_ev):
        assert "uaccess" not in _tags(out[sp]), f"{sp}:\n{out[sp]}"
    assert "ID_INPUT_TABLET=1" in _props(out[pen_ev])
    assert "ID_INPUT_TOUCHPAD=1" in _props(out[pad_ev])
    assert "ID_INPUT_KEY=1" in _props(out[kbd_ev])  # keys only: not a pointer device
    for sp, text in out.items():
        ours = [line for line in text.splitlines() if RULES_NAME in line]
        assert ours, sp  # our file was read
        # udev reports a bad line as "<file>:<line> Invalid ..., ignoring"
        assert not [x for x in ours if "nvalid" in x or "ignoring" in x], ours
