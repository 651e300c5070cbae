"""`stiction doctor` against umockdev-mocked devices, through the production drivers.

One testbed holds real devices' descriptions (evemu recordings and hid-recorder
descriptors from shared/data): tablets that open, a touchpad that reports no
resolution, a touchpad another program has grabbed (EBUSY from EVIOCGRAB), a
pen and a hidraw tablet whose nodes the user may not open, and a Huion tablet
whose hidraw node is open to the user but whose USB node (needed for the
vendor initialisation through pyusb) is not.

"May not open" is the kernel's own permission check on the mocked node's pty
(mode 000). Root bypasses permission bits through CAP_DAC_OVERRIDE and
CAP_DAC_READ_SEARCH, so when the tests run as root (CI does) the doctor runs
with those two capabilities dropped from its bounding set (setpriv): it is
then subject to mode bits like any user, while everything else (the venv in
/root, the testbed owned by root) stays reachable as the owner.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from setup_mocks import Node, evdev_node, hidraw_node

from stiction.drivers.evdev.recording import load as load_evdev
from stiction.drivers.hid.recording import load_recording

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
CONTROLLER = HERE / "setup_doctor_controller.py"
SYSTEM_PY = "/usr/bin/python3"
# sudo's PATH rarely has the venv, so the fix names this installation's stiction
INSTALL = f"sudo {Path(sys.executable).parent / 'stiction'} udev install"

pytestmark = pytest.mark.umockdev


def _need_tools() -> None:
    if shutil.which("umockdev-run") is None:
        pytest.fail("umockdev is not installed (Debian package umockdev; `make test` installs it)")
    probe = subprocess.run(
        [SYSTEM_PY, "-c", "import gi; gi.require_version('UMockdev', '1.0')"],
        capture_output=True,
        check=False,
    )
    if probe.returncode != 0:
        pytest.fail("GI for umockdev is missing (Debian gir1.2-umockdev-1.0 and python3-gi)")


def _as_user() -> list[str]:
    """Prefix that makes the doctor subject to file modes even when the tests run as root."""
    if os.geteuid() != 0:
        return []
    exe = shutil.which("setpriv")
    if exe is None:
        pytest.fail("running as root needs setpriv (util-linux) to drop CAP_DAC_OVERRIDE")
    return [exe, "--bounding-set=-dac_override,-dac_read_search", "--"]


def _evdev(data: Path, name: str, num: int, out: Path, udev: dict[str, str]) -> Node:
    return evdev_node(load_evdev(data / name).description, num, out, udev)


def _run_controller(
    tmp: Path,
    nodes: list[Node],
    doctor_args: tuple[str, ...],
    *,
    busy: tuple[Node, ...] = (),
    deny: tuple[str, ...] = (),
    spec_name: str = "spec.json",
) -> dict[str, Any]:
    """Run `stiction doctor *doctor_args` under the umockdev controller; its JSON result."""
    spec = {
        "devices": [str(n.umockdev) for n in nodes],
        "ioctl": {n.dev: str(n.ioctl) for n in nodes if n not in busy},
        "busy": {n.dev: str(n.ioctl) for n in busy},
        "deny": list(deny),
        "argv": [*_as_user(), sys.executable, "-m", "stiction", "doctor", *doctor_args],
    }
    spec_path = tmp / spec_name
    spec_path.write_text(json.dumps(spec))
    # XDG_CONFIG_HOME in tmp: a config of the machine's user must not change the result
    env = dict(os.environ, XDG_CONFIG_HOME=str(tmp / "config"))
    proc = subprocess.run(
        [SYSTEM_PY, str(CONTROLLER), str(spec_path)],
        capture_output=True,
        text=True,
        timeout=90,
        check=False,
        cwd=REPO,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    result: dict[str, Any] = json.loads(proc.stdout)
    return result


def _run_doctor(
    tmp: Path,
    nodes: list[Node],
    *,
    busy: tuple[Node, ...] = (),
    deny: tuple[str, ...] = (),
    args: tuple[str, ...] = (),
) -> dict[str, Any]:
    result = _run_controller(tmp, nodes, ("--json", *args), busy=busy, deny=deny)
    assert result["stdout"].strip(), result["stderr"]
    result["report"] = json.loads(result["stdout"])
    return result


def _by_path(report: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {d["path"]: d for d in report["devices"]}


@pytest.fixture(scope="module")
def machine(
    tmp_path_factory: pytest.TempPathFactory, evdev_data: Path, hid_data: Path
) -> dict[str, Any]:
    """Every kind of problem on one mocked machine, and the doctor's verdict on it."""
    _need_tools()
    tmp = tmp_path_factory.mktemp("doctor")
    pen = _evdev(evdev_data, "wacom-cintiq-13hd-touch-pen.evemu", 5, tmp, {"ID_INPUT_TABLET": "1"})
    nosize = _evdev(
        evdev_data, "synaptics-touchpad.hp8470p.desc", 6, tmp, {"ID_INPUT_TOUCHPAD": "1"}
    )
    grabbed = _evdev(
        evdev_data, "cypress-trackpad.two-finger-press.evemu", 7, tmp, {"ID_INPUT_TOUCHPAD": "1"}
    )
    locked = _evdev(evdev_data, "uc-logic-wp5540u-pen.evemu", 8, tmp, {"ID_INPUT_TABLET": "1"})
    xp = load_recording(hid_data / "xp-pen-artist-10s.hid")
    hid_ok = hidraw_node(xp.name, xp.vid, xp.pid, xp.descriptor, 5, tmp)
    hid_locked = hidraw_node(xp.name, xp.vid, xp.pid, xp.descriptor, 6, tmp)
    huion = load_recording(hid_data / "huion-hs610.hid")
    hid_huion = hidraw_node(huion.name, huion.vid, huion.pid, huion.descriptor, 7, tmp)
    nodes = [pen, nosize, grabbed, locked, hid_ok, hid_locked, hid_huion]
    assert hid_huion.usb_dev is not None
    result = _run_doctor(
        tmp,
        nodes,
        busy=(grabbed,),
        deny=(locked.dev, hid_locked.dev, hid_huion.usb_dev),
    )
    return {"result": result, "nodes": nodes, "tmp": tmp}


def test_every_candidate_is_listed(machine: dict[str, Any]) -> None:
    report = machine["result"]["report"]
    assert sorted(_by_path(report)) == sorted(n.dev for n in machine["nodes"])
    assert report["ok"] is False
    assert machine["result"]["returncode"] == 1


def test_openable_devices_are_ok(machine: dict[str, Any]) -> None:
    found = _by_path(machine["result"]["report"])
    for path in ("/dev/input/event5", "/dev/hidraw5"):
        assert found[path]["ok"] is True, found[path]
        assert found[path]["problem"] is None


def test_unreadable_nodes_are_permission_problems_with_the_udev_fix(
    machine: dict[str, Any],
) -> None:
    found = _by_path(machine["result"]["report"])
    for path in ("/dev/input/event8", "/dev/hidraw6"):
        d = found[path]
        assert d["problem"] == "permission", d
        assert "Permission denied" in d["detail"]
        assert INSTALL in d["fix"]
    assert found["/dev/hidraw6"]["kind"] == "pen"  # known as a digitizer without opening it


def test_grabbed_device_is_busy_and_says_how_to_find_the_grabber(
    machine: dict[str, Any],
) -> None:
    d = _by_path(machine["result"]["report"])["/dev/input/event7"]
    assert d["problem"] == "busy", d
    assert "fuser -v /dev/input/event7" in d["fix"]
    assert machine["result"]["grab_attempts"] == 1  # the doctor asked the kernel, once


def test_device_without_resolution_says_where_to_configure_its_size(
    machine: dict[str, Any],
) -> None:
    d = _by_path(machine["result"]["report"])["/dev/input/event6"]
    assert d["problem"] == "no-size", d
    config = machine["tmp"] / "config" / "stiction" / "stictiond.toml"
    assert str(config) in d["fix"]
    assert 'spec = "/dev/input/event6"' in d["fix"]
    assert "size_mm = [width, height]" in d["fix"]


def test_huion_without_usb_access_is_a_vendor_init_problem(machine: dict[str, Any]) -> None:
    d = _by_path(machine["result"]["report"])["/dev/hidraw7"]
    assert d["problem"] == "vendor-init", d
    assert "string descriptor" in d["detail"]
    assert "Access denied" in d["detail"]  # libusb could not open the USB node
    assert "/dev/bus/usb/001/017" in d["fix"]
    assert INSTALL in d["fix"]


def test_configured_size_fixes_the_device_and_exit_status_is_zero(
    tmp_path: Path, evdev_data: Path
) -> None:
    """The fix the doctor prints, applied as printed, makes the same device usable."""
    _need_tools()
    nosize = _evdev(
        evdev_data, "synaptics-touchpad.hp8470p.desc", 6, tmp_path, {"ID_INPUT_TOUCHPAD": "1"}
    )
    before = _run_doctor(tmp_path, [nosize])
    fix = before["report"]["devices"][0]["fix"]
    assert before["returncode"] == 1
    config = tmp_path / "config" / "stiction" / "stictiond.toml"
    assert str(config) in fix
    config.parent.mkdir(parents=True)
    config.write_text('[[devices]]\nspec = "/dev/input/event6"\nsize_mm = [100, 60]\n')
    after = _run_doctor(tmp_path, [nosize])
    assert after["report"]["devices"][0]["ok"] is True, after["report"]
    assert after["report"]["ok"] is True
    assert after["returncode"] == 0


def test_human_output_names_problem_and_fix(tmp_path: Path, evdev_data: Path) -> None:
    _need_tools()
    locked = _evdev(evdev_data, "uc-logic-wp5540u-pen.evemu", 8, tmp_path, {"ID_INPUT_TABLET": "1"})
    spec_nodes = [locked]
    result = _run_doctor(tmp_path, spec_nodes, deny=(locked.dev,))
    assert result["returncode"] == 1
    # the same run without --json
    human = _run_doctor_text(tmp_path, spec_nodes, deny=(locked.dev,))
    assert "PROBLEM (permission)" in human
    assert f"fix: install stiction's udev rule: `{INSTALL}`" in human
    assert "0 of 1 devices usable" in human


def _run_doctor_text(tmp: Path, nodes: list[Node], deny: tuple[str, ...]) -> str:
    out: str = _run_controller(tmp, nodes, (), deny=deny, spec_name="spec-text.json")["stdout"]
    return out


def test_hidraw_tablet_without_size_then_configured(tmp_path: Path, hid_data: Path) -> None:
    """A tablet outside the table whose descriptor has no physical size (a Huion clone)."""
    _need_tools()
    rec = load_recording(hid_data / "huion-hs610.hid")  # unit in^3: no usable size
    node = hidraw_node("Tablet Clone", 0x1234, 0x5678, rec.descriptor, 5, tmp_path)
    before = _run_doctor(tmp_path, [node])
    d = before["report"]["devices"][0]
    assert (d["kind"], d["problem"]) == ("pen", "no-size"), d
    assert 'spec = "/dev/hidraw5"' in d["fix"]
    config = tmp_path / "config" / "stiction" / "stictiond.toml"
    config.parent.mkdir(parents=True)
    config.write_text('[[devices]]\nspec = "1234:5678"\nsurface_size = [0.254, 0.159]\n')
    after = _run_doctor(tmp_path, [node])
    assert after["report"]["devices"][0]["ok"] is True, after["report"]
    assert after["returncode"] == 0


def test_no_devices_is_not_ok(tmp_path: Path) -> None:
    _need_tools()
    result = _run_doctor(tmp_path, [])
    assert result["report"]["devices"] == []
    assert result["report"]["ok"] is False
    assert result["returncode"] == 1


def test_a_config_that_is_a_directory_or_fifo_is_named_as_such(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Both were reported as 'no such config file', which they are not."""
    from stiction.cli import main

    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    for path in (tmp_path, fifo):
        assert main(["doctor", "--config", str(path)]) == 2
        assert "not a regular file" in capsys.readouterr().err
    assert main(["doctor", "--config", str(tmp_path / "none.toml")]) == 2
    assert "no such config file" in capsys.readouterr().err
