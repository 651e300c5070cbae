"""Which backend reads a tablet that has both a hidraw and an evdev node.

The umockdev tests mock one USB tablet whose hidraw node and event node hang
below the same HID device, as the kernel shows a tablet its driver knows,
and run the real `stiction devices`, `stiction doctor` and `stictiond`
against it (hidapi's hidraw backend and python-evdev, unpatched). The unit
tests at the end give the rule's other branches on hand-made nodes.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pytest
from paired_mock import PairedMock, write_pair

from stiction.drivers.discovery import choose, select
from stiction.drivers.evdev.recording import load
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.info import DeviceInfo

# pid.codes' test VID:PID (https://pid.codes/1209/0001/): in no device table,
# so sizes come only from what each mocked node itself reports.
VID, PID = 0x1209, 0x0001
SPEC = "1209:0001"


def _need_umockdev() -> None:
    if shutil.which("umockdev-run") is None:
        pytest.fail("umockdev is not installed (Debian package umockdev; `make test` installs it)")


def _tablet(tmp: Path, hid_data: Path, evdev_data: Path, resolution: bool) -> PairedMock:
    """The XP-Pen Artist 10S descriptor (it has a physical size) beside the UC-Logic
    WP5540U's event node, with or without the kernel's resolution on X/Y."""
    _need_umockdev()
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    desc = load(evdev_data / "uc-logic-wp5540u-pen.evemu").description
    if not resolution:
        desc = desc.with_resolution(0, 0)
    return write_pair(tmp, "Test Tablet", VID, PID, rec.descriptor, desc)


def _devices(mock: PairedMock) -> dict[str, dict[str, object]]:
    done = mock.run([sys.executable, "-m", "stiction", "devices", "--json"])
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    return {d["path"]: d for d in json.loads(done.stdout)}


def _stictiond(mock: PairedMock, tmp: Path, *args: str) -> str:
    """Run the daemon briefly; its log (stderr)."""
    argv = [sys.executable, "-m", "stiction.daemon.main", "--seconds", "0.2", "--no-hotplug"]
    argv += ["--pub", f"ipc://{tmp}/pub", "--control", f"ipc://{tmp}/ctl", *args]
    done = mock.run(argv)
    assert done.returncode == 0, done.stderr
    return done.stderr


@pytest.mark.umockdev
def test_a_tablet_the_kernel_sizes_is_read_through_evdev(
    tmp_path: Path, hid_data: Path, evdev_data: Path
) -> None:
    mock = _tablet(tmp_path / "mock", hid_data, evdev_data, resolution=True)
    found = _devices(mock)
    hid, ev = found[mock.hidraw], found[mock.event]
    assert hid["hid_device"] == ev["hid_device"] is not None  # paired through sysfs
    assert (ev["chosen"], ev["sized"], ev["size_from"]) == (True, True, "kernel")
    assert "reports a resolution" in str(ev["reason"])
    assert hid["chosen"] is False and mock.event in str(hid["reason"])
    # the keys `stiction devices --json` had before stay
    assert {"path", "backend", "vid", "pid", "name", "kind", "problem", "vid_pid"} <= set(ev)
    text = mock.run([sys.executable, "-m", "stiction", "devices"]).stdout
    assert f"{mock.event}\t{SPEC}\tpen\tevdev\t" in text
    assert "\tok\tchosen: the kernel driver knows it" in text
    assert "\tok\tnot chosen: read through /dev/input/event5 (evdev)" in text


@pytest.mark.umockdev
def test_an_evdev_node_without_resolution_leaves_it_to_hidraw(
    tmp_path: Path, hid_data: Path, evdev_data: Path
) -> None:
    mock = _tablet(tmp_path / "mock", hid_data, evdev_data, resolution=False)
    found = _devices(mock)
    hid, ev = found[mock.hidraw], found[mock.event]
    assert (ev["chosen"], ev["sized"]) == (False, False)
    assert (hid["chosen"], hid["sized"], hid["size_from"]) == (True, True, "descriptor")
    assert hid["reason"] == (
        "its evdev node has no size; the HID descriptor (or device table) gives the size"
    )


@pytest.mark.umockdev
def test_the_daemon_with_no_device_reads_the_tablet_through_evdev(
    tmp_path: Path, hid_data: Path, evdev_data: Path
) -> None:
    mock = _tablet(tmp_path / "mock", hid_data, evdev_data, resolution=True)
    log = _stictiond(mock, tmp_path)
    found = [line.split(": ", 1)[1] for line in log.splitlines() if "device_found" in line]
    assert found == [
        f"device_found node={mock.event} backend=evdev reason=the kernel driver knows it: "
        "its evdev node reports a resolution"
    ], log
    assert "devices=test-tablet-pen" in log  # the evdev node's name, slugged


@pytest.mark.umockdev
@pytest.mark.parametrize(
    ("resolution", "spec", "node"),
    [
        (True, SPEC, "/dev/input/event5"),  # the rule
        (True, f"hidraw:{SPEC}", None),  # asked for: hidraw, opened by VID:PID directly
        (False, SPEC, "/dev/hidraw5"),  # the rule
        (False, f"evdev:{SPEC}", "/dev/input/event5"),  # asked for, against the rule
        (True, "Test Tablet", "/dev/input/event5"),  # a name: the rule
        (True, "hidraw:name:Test Tablet", "/dev/hidraw5"),  # a name, asked for
    ],
)
def test_a_vid_pid_or_named_device_follows_the_rule_or_the_backend_asked_for(
    tmp_path: Path,
    hid_data: Path,
    evdev_data: Path,
    resolution: bool,
    spec: str,
    node: str | None,
) -> None:
    mock = _tablet(tmp_path / "mock", hid_data, evdev_data, resolution)
    log = _stictiond(mock, tmp_path, "-v", "--device", spec)
    target = "Test Tablet" if "Test Tablet" in spec else SPEC
    if node is None:
        assert "device_backend" not in log and "devices=hidraw-hidraw5" in log, log
    else:
        assert f"device_backend spec={target} node={node} " in log, log
    if spec.startswith("evdev:"):  # honoured: and so it meets the node's missing size
        assert "reason=asked for evdev" in log
        assert "device_absent spec=evdev:1209:0001" in log and "no resolution" in log, log
    else:
        assert "device_absent" not in log, log


@pytest.mark.umockdev
@pytest.mark.parametrize("spec", [SPEC, "name:test tablet"])
def test_the_config_backend_key_is_honoured_and_the_doctor_says_so(
    tmp_path: Path, hid_data: Path, evdev_data: Path, spec: str
) -> None:
    mock = _tablet(tmp_path / "mock", hid_data, evdev_data, resolution=True)
    config = tmp_path / "stictiond.toml"
    config.write_text(f'[[devices]]\nspec = "{spec}"\nbackend = "hidraw"\n')
    done = mock.run([sys.executable, "-m", "stiction", "doctor", "--json", "--config", str(config)])
    report = json.loads(done.stdout)
    by_path = {d["path"]: d for d in report["devices"]}
    assert by_path[mock.hidraw]["chosen"] is True
    assert by_path[mock.hidraw]["reason"] == "the config asks for backend = 'hidraw'"
    assert by_path[mock.event]["chosen"] is False
    log = _stictiond(mock, tmp_path, "-v", "--config", str(config))
    assert "device_absent" not in log and "devices=hidraw-hidraw5" in log, log


@pytest.mark.umockdev
def test_the_doctor_names_the_choice_and_a_problem_on_the_unused_node_does_not_fail_it(
    tmp_path: Path, hid_data: Path, evdev_data: Path
) -> None:
    """The issue's Huion: a hidraw path without a size beside a kernel-sized evdev node."""
    _need_umockdev()
    clone = load_recording(hid_data / "huion-hs610.hid")  # unit in^3: no usable size
    desc = load(evdev_data / "uc-logic-wp5540u-pen.evemu").description
    mock = write_pair(tmp_path / "mock", "Tablet Clone", VID, PID, clone.descriptor, desc)
    config = tmp_path / "empty.toml"
    config.write_text("")
    done = mock.run([sys.executable, "-m", "stiction", "doctor", "--config", str(config)])
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    assert "    chosen: the kernel driver knows it: its evdev node reports a resolution" in out
    assert "    not chosen: read through /dev/input/event5 (evdev)" in out
    assert "    problem (no-size):" in out  # reported, in lower case: not what is read
    assert "1 of 1 devices usable" in out


def _node(path: str, backend: str, sized: bool | None, kind: str = "pen") -> DeviceInfo:
    return DeviceInfo(path, backend, 1, 2, "t", kind, None, "/sys/x/0003:0001:0002.0001", sized)


def _chosen(nodes: list[DeviceInfo], **kw: object) -> list[str]:
    return [i.path for i in choose(nodes, **kw) if i.chosen]  # type: ignore[arg-type]


def test_neither_sized_falls_back_to_evdev_and_says_to_configure() -> None:
    out = choose(
        [_node("/dev/hidraw1", "hidraw", False), _node("/dev/input/event1", "evdev", False)]
    )
    assert [i.chosen for i in out] == [False, True]
    assert "configure size_mm" in str(out[1].reason)


def test_nodes_that_cannot_be_opened_fall_back_to_evdev_and_say_why() -> None:
    out = choose([_node("/dev/hidraw1", "hidraw", None), _node("/dev/input/event1", "evdev", None)])
    assert [i.chosen for i in out] == [False, True]
    assert "could not be opened" in str(out[1].reason)


def test_one_unsized_event_node_of_a_device_leaves_it_to_hidraw() -> None:
    nodes = [
        _node("/dev/hidraw1", "hidraw", True),
        _node("/dev/input/event1", "evdev", True),
        _node("/dev/input/event2", "evdev", False, kind="touchpad"),
    ]
    assert _chosen(nodes) == ["/dev/hidraw1"]


def test_unpaired_nodes_are_each_read_and_other_kinds_never() -> None:
    alone = DeviceInfo("/dev/hidraw2", "hidraw", 3, 4, "kbd", "other")
    pen = DeviceInfo("/dev/input/event9", "evdev", 3, 4, "pen", "pen")
    out = choose([alone, pen])
    assert [i.chosen for i in out] == [False, True]
    assert out[1].reason == "no hidraw node for it: read through evdev"


def test_prefer_overrides_the_rule_for_its_device_only() -> None:
    nodes = [_node("/dev/hidraw1", "hidraw", True), _node("/dev/input/event1", "evdev", True)]
    assert _chosen(nodes, prefer=lambda i: "hidraw") == ["/dev/hidraw1"]
    assert _chosen(nodes, prefer=lambda i: None) == ["/dev/input/event1"]


def test_select_matches_a_device_by_any_of_its_nodes() -> None:
    nodes = choose(
        [
            DeviceInfo("/dev/hidraw1", "hidraw", 1, 2, "Tablet", "pen", None, "/sys/a", True),
            DeviceInfo(
                "/dev/input/event1", "evdev", 1, 2, "Tablet Pen", "pen", None, "/sys/a", True
            ),
        ]
    )
    by_name = select(nodes, lambda i: i.name == "Tablet")
    assert [i.path for i in by_name] == ["/dev/input/event1"]
    assert [i.path for i in select(nodes, lambda i: True, "hidraw")] == ["/dev/hidraw1"]


def test_a_node_whose_probe_crashes_is_listed_unpaired(monkeypatch: pytest.MonkeyPatch) -> None:
    from stiction.drivers import discovery

    odd = DeviceInfo("/dev/input/event3", "evdev", 1, 2, "odd", "pen")
    monkeypatch.setattr(discovery, "discover_nodes", lambda: [odd])

    def crash(info: DeviceInfo, sysfs: Path = discovery.SYSFS_CLASS) -> DeviceInfo:
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(discovery, "annotate", crash)
    (out,) = discovery.discover_all()
    assert (out.path, out.hid_device, out.sized, out.chosen) == (odd.path, None, None, True)
