"""The production hidraw backend (hidapi's `hidraw` module) against umockdev-mocked devices.

Each test generates the .umockdev/.ioctl/.script files from a real tablet's
descriptor and recorded reports, runs the backend in a subprocess under
umockdev-run and compares what it produced with the same reports decoded
directly. Sample times are not compared: hidraw has no timestamps and
umockdev replays only roughly in real time.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import pytest
from umockdev_hidraw import write_mock

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import lookup
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream

HERE = Path(__file__).resolve().parent
HELPER = HERE / "hidraw_reader_helper.py"
N_REPORTS = 300

pytestmark = pytest.mark.umockdev


def _umockdev_run() -> str:
    exe = shutil.which("umockdev-run")
    if exe is None:
        pytest.fail(
            "umockdev-run is not installed (Debian package umockdev; `make test` installs it)"
        )
    return exe


def _under_umockdev(files, *argv: str) -> list[str]:  # type: ignore[no-untyped-def]
    """The command running `argv` under umockdev-run with the mocked node of `files`."""
    return [
        _umockdev_run(),
        "--device",
        str(files.device),
        "--ioctl",
        f"{files.dev_node}={files.ioctl}",
        "--script",
        f"{files.dev_node}={files.script}",
        "--",
        *argv,
    ]


def _run(tmp: Path, files, wanted: int, *extra: str) -> list[dict]:  # type: ignore[no-untyped-def]
    cmd = _under_umockdev(files, sys.executable, str(HELPER), files.dev_node, str(wanted), *extra)
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60, cwd=tmp)
    assert proc.returncode == 0, proc.stderr
    return [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]


def _direct(name: str, descriptor: bytes, vid: int, pid: int, reports: list[bytes]) -> list[dict]:
    stream = ReportStream(parse_descriptor(descriptor), name, None, lookup(vid, pid))
    out = []
    for i, data in enumerate(reports):
        for s in stream.feed(float(i), data):
            d = asdict(s)
            d["tool"] = s.tool.value
            out.append(d)
    return out


@pytest.mark.parametrize("recording", ["xp-pen-artist-10s", "wacom-penpartner"])
def test_hidraw_backend_reads_recorded_reports(
    tmp_path: Path, hid_data: Path, recording: str
) -> None:
    rec = load_recording(hid_data / f"{recording}.hid")
    reports = [ev.data for ev in rec.events[:N_REPORTS]]
    files = write_mock(tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, reports)
    lines = _run(tmp_path, files, len(reports), "--discover")

    found = [x["discover"] for x in lines if "discover" in x]
    expected = {
        "path": files.dev_node,
        "backend": "hidraw",
        "vid": rec.vid,
        "pid": rec.pid,
        "name": rec.name,
        "kind": "pen",
        "problem": None,
    }
    # the backend's own discovery; pairing with evdev nodes (chosen, reason) is discovery.py's
    assert [{k: f[k] for k in expected} for f in found] == [expected]
    head = next(x for x in lines if "kind" in x)
    assert head["kind"] == "pen"
    tail = lines[-1]
    assert tail["error"] is None
    assert tail["stats"]["reports"] == len(reports)

    got = [x for x in lines if "x" in x]
    expected = _direct(rec.name, rec.descriptor, rec.vid, rec.pid, reports)
    assert len(got) == len(expected) > 100
    for g, e in zip(got, expected, strict=True):
        g.pop("t")
        e.pop("t")
        assert g == e


def test_unplug_reports_closes_and_raises(tmp_path: Path, hid_data: Path) -> None:
    """A device that vanishes mid-stream: samples() raises DeviceError, nothing read is lost."""
    _umockdev_run()
    system_python = "/usr/bin/python3"
    probe = subprocess.run(
        [system_python, "-c", "import gi; gi.require_version('UMockdev', '1.0')"],
        capture_output=True,
        timeout=30,
    )
    if probe.returncode != 0:
        pytest.fail("system python3 lacks gi/UMockdev (Debian: python3-gi gir1.2-umockdev-1.0)")
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    reports = [ev.data for ev in rec.events[:200]]
    files = write_mock(tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, reports)
    cmd = [
        system_python,
        str(HERE / "umockdev_unplug_controller.py"),
        str(files.device),
        str(files.ioctl),
        str(files.script),
        files.dev_node,
        "--",
        sys.executable,
        str(HELPER),
        files.dev_node,
        str(len(reports)),
        "--until-error",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(x) for x in proc.stdout.splitlines() if x.startswith("{")]
    assert lines[-1] == {"controller_unplugged": True}
    final = lines[-2]
    assert final["stats"]["reports"] == len(reports)
    assert final["error"] is not None and "unplugged" in final["error"]
    assert "device gone" in proc.stderr  # reported in the log, once
    got = [x for x in lines if "x" in x]
    expected = _direct(rec.name, rec.descriptor, rec.vid, rec.pid, reports)
    assert [{**g, "t": 0} for g in got] == [{**e, "t": 0} for e in expected]


def _huion_v2_raw(x: int, y: int, pressure: int, tip: bool, frame: bool = False) -> bytes:
    """A pen report as a Huion tablet sends it in full-resolution (v2) mode: fragmented X/Y."""
    flags = 0x80 | (0x01 if tip else 0) | (0x20 if frame else 0)
    return bytes(
        [
            0x08,
            flags,
            x & 0xFF,
            (x >> 8) & 0xFF,
            y & 0xFF,
            (y >> 8) & 0xFF,
            pressure & 0xFF,
            pressure >> 8,
            x >> 16,
            y >> 16,
            10,
            0xF6,
        ]
    )


def test_huion_tablet_initialised_and_read_through_hidraw(tmp_path: Path, hid_data: Path) -> None:
    """Firmware descriptor on the node, pyusb init, then v2 reports decoded to metres."""
    from stiction.drivers.fake.strokes import SCRIPTS, render

    rec = load_recording(hid_data / "huion-hs610.hid")  # 256c:006d firmware descriptor
    states = render(SCRIPTS["stroke"](0.254, 0.15875))[:200]
    reports = [
        _huion_v2_raw(round(s.x / 0.254 * 50800), round(s.y / 0.15875 * 31750), 4000, s.tip)
        for s in states
    ]
    reports.insert(50, _huion_v2_raw(0, 0, 0, False, frame=True))  # a frame-button report
    files = write_mock(tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, reports)
    lines = _run(tmp_path, files, len(reports), "--huion-usb")
    head = next(x for x in lines if "kind" in x)
    assert head["size"] == pytest.approx([0.254, 0.15875])
    # A v2 tablet has no in-range bit: a pause of 100 ms ends the contact. Under
    # load umockdev may pause that long; such leave samples are not what is compared.
    samples = [x for x in lines if "x" in x]
    got = [x for x in samples if x["in_range"]]
    leaves = len(samples) - len(got)
    tail = lines[-1]
    assert tail["stats"] == {
        "reports": len(reports),
        "samples": len(states) + leaves,
        "ignored": 1,
    }
    for g, s in zip(got, states, strict=True):
        assert g["x"] == pytest.approx(s.x, abs=0.254 / 50800)
        assert g["y"] == pytest.approx(s.y, abs=0.15875 / 31750)
        assert (g["tip"], g["in_range"]) == (s.tip, True)
        assert g["pressure"] == pytest.approx(4000 / 8191)
        assert (g["tilt_x"], g["tilt_y"]) == (10.0, -10.0)


def test_uclogic_v1_tablet_recorded_reports_through_init(tmp_path: Path, hid_data: Path) -> None:
    """Yiynova MVP20U (5543:004d): init answers string 100, real reports decode as the replay does.

    The recording was made in the tablet's initialised (v1) mode. Read live,
    stiction initialises it (pyusb backend object answering with the
    parameters its descriptor implies: 34242 x 18794 at 2000 lpi, 2048
    pressure levels) and decodes with the generated v1 descriptor; the
    replay decodes with the firmware descriptor and the table's fix-up.
    Both must give the same positions, contact states and pressure.
    """
    rec = load_recording(hid_data / "yiynova-mvp20u-rh.hid")
    reports = [ev.data for ev in rec.events[:400]]
    files = write_mock(tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, reports)
    lines = _run(
        tmp_path, files, len(reports), "--huion-usb=v1:34242,18794,2047,2000", "--usb-id=5543:004d"
    )
    assert lines[-1]["error"] is None
    got = [x for x in lines if "x" in x]
    expected = _direct(rec.name, rec.descriptor, rec.vid, rec.pid, reports)
    keys = ("tip", "in_range", "pressure")
    assert len(got) == len(expected) > 100
    assert sum(1 for e in expected if e["in_range"] and not e["tip"]) > 10  # hovering is seen
    for g, e in zip(got, expected, strict=True):
        assert {k: g[k] for k in keys} == {k: e[k] for k in keys}
        assert g["x"] == pytest.approx(e["x"], abs=1e-5)
        assert g["y"] == pytest.approx(e["y"], abs=1e-5)


def test_record_writes_what_the_device_sent(tmp_path: Path, hid_data: Path) -> None:
    """`stiction hid record` on a mocked node: a hid-recorder file that reads back identically."""
    from stiction.drivers.hid.recording import parse_recording

    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    reports = [ev.data for ev in rec.events[:120]]
    files = write_mock(tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, reports)
    argv = (sys.executable, "-m", "stiction", "hid", "record", files.dev_node)
    cmd = _under_umockdev(files, *argv, "--count", str(len(reports)))
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    back = parse_recording(proc.stdout, "recorded")
    assert (back.name, back.bus, back.vid, back.pid) == (rec.name, 3, rec.vid, rec.pid)
    assert back.descriptor == rec.descriptor
    assert [ev.data for ev in back.events] == reports
    times = [ev.t for ev in back.events]
    assert times[0] == 0.0 and times == sorted(times)
    assert f"{len(reports)} reports recorded" in proc.stderr


def test_output_report_init_from_a_user_table(
    tmp_path: Path, hid_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A user's table entry makes the backend send an output report before reading.

    umockdev replays the script in order: the reports come only after the
    program wrote exactly the expected bytes.
    """
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    reports = [ev.data for ev in rec.events[:60]]
    switch = bytes.fromhex("02b00400000000000000")
    files = write_mock(
        tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, reports, expect_writes=[switch]
    )
    table = tmp_path / "hid-devices.toml"
    table.write_text(
        f'[[device]]\nid = "{rec.vid:04x}:{rec.pid:04x}"\ninit = "output:{switch.hex()}"\n'
        'source = "test"\n'
    )
    monkeypatch.setenv("STICTION_HID_DEVICES", str(table))  # inherited by the subprocess
    lines = _run(tmp_path, files, len(reports))
    assert lines[-1]["stats"]["reports"] == len(reports)
    assert lines[-1]["error"] is None


def test_a_live_open_matches_catalogue_entries_by_usb_string(
    tmp_path: Path, hid_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An entry that needs USB string 201 applies live: the backend reads the string
    through pyusb, the entry's output report is sent, and only then (umockdev's
    script) do the reports come. Without the string read and matched, none would."""
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    reports = [ev.data for ev in rec.events[:40]]
    switch = bytes.fromhex("02b00400000000000000")
    files = write_mock(
        tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, reports, expect_writes=[switch]
    )
    table = tmp_path / "hid-devices.toml"
    table.write_text(
        f'[[device]]\nmatch = {{ id = "{rec.vid:04x}:{rec.pid:04x}", '
        'strings = { 201 = "^TEST_FW_\\\\d+$" } }\n'
        f'init = "output:{switch.hex()}"\nsource = "test"\n'
    )
    monkeypatch.setenv("STICTION_HID_DEVICES", str(table))
    usb_id = f"--usb-id={rec.vid:04x}:{rec.pid:04x}"
    lines = _run(tmp_path, files, len(reports), usb_id, "--usb-string=201:TEST_FW_42")
    assert lines[-1]["stats"]["reports"] == len(reports)
    assert lines[-1]["error"] is None


def test_failing_feature_report_init_is_a_clear_error(
    tmp_path: Path, hid_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """umockdev answers no HIDIOCSFEATURE: the init fails, open_hidraw says which and why."""
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    files = write_mock(tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, [])
    table = tmp_path / "hid-devices.toml"
    table.write_text(
        f'[[device]]\nid = "{rec.vid:04x}:{rec.pid:04x}"\nname = "XP-Pen test"\n'
        'init = "feature:0202"\nsource = "test"\n'
    )
    monkeypatch.setenv("STICTION_HID_DEVICES", str(table))
    lines = _run(tmp_path, files, 0)
    (err,) = [x["open_error"] for x in lines if "open_error" in x]
    assert err.startswith("XP-Pen test: vendor initialisation (feature:0202) failed")


def test_discover_lists_a_huion_in_firmware_mode_without_a_problem(
    tmp_path: Path, hid_data: Path
) -> None:
    """Its descriptor lacks a size, but opening it initialises it: no problem to report."""
    rec = load_recording(hid_data / "huion-hs610.hid")
    files = write_mock(tmp_path, rec.name, rec.vid, rec.pid, rec.descriptor, [])
    lines = _run(tmp_path, files, 0, "--discover", "--huion-usb")
    (info,) = [x["discover"] for x in lines if "discover" in x]
    assert (info["kind"], info["problem"], info["vid"], info["pid"]) == ("pen", None, 0x256C, 0x6D)


def test_discover_explains_a_missing_size(tmp_path: Path, hid_data: Path) -> None:
    rec = load_recording(hid_data / "huion-hs610.hid")
    files = write_mock(tmp_path, rec.name, 0x1234, 0x5678, rec.descriptor, [])  # no table entry
    lines = _run(tmp_path, files, 0, "--discover")
    (info,) = [x["discover"] for x in lines if "discover" in x]
    assert info["kind"] == "pen"
    assert "no physical size" in info["problem"] and "size_mm" in info["problem"]
    assert any("open_error" in x for x in lines)  # and opening it says the same
