"""The production python-evdev reader against umockdev-mocked /dev/input nodes.

Each test writes the .umockdev/.ioctl/.events files from a shared recording,
runs stiction's own code in a subprocess under umockdev-run (the preload
library fakes the node, answers python-evdev's ioctls and replays the events
with their recorded kernel times) and compares what it read with what the
recording decodes to directly. Assertions are on content and kernel
timestamps, never on arrival times.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from evdev_mockfiles import (
    gi_available,
    run_controller,
    run_under_umockdev,
    stiction_cmd,
    umockdev_available,
    write,
    write_replug_pair,
)

from stiction.drivers.evdev import replay, sizes
from stiction.drivers.evdev.cli import frame_json
from stiction.drivers.evdev.frames import FrameAssembler
from stiction.drivers.evdev.recording import load
from stiction.drivers.evdev.units import SurfaceUnits

pytestmark = [
    pytest.mark.umockdev,
    pytest.mark.skipif(not umockdev_available(), reason="umockdev-run not installed"),
]

FAST = [  # a pen tablet, a pen display's touchscreen and two touchpads; < 1 s each
    ("wacom-cintiq-13hd-touch-pen.evemu", {"ID_INPUT_TABLET": "1"}),
    ("wacom-cintiq-13hd-touch-finger.evemu", {"ID_INPUT_TOUCHSCREEN": "1"}),
    ("cypress-trackpad.two-finger-press.evemu", {"ID_INPUT_TOUCHPAD": "1"}),
]
SLOW = [
    ("wacom-cintiq-12wx.evemu", {"ID_INPUT_TABLET": "1"}),
    ("wacom-intuos4-6x9.desc", {"ID_INPUT_TABLET": "1"}),
    ("uc-logic-wp5540u-pen.evemu", {"ID_INPUT_TABLET": "1"}),
    ("elantech-touchpad.samsung-700z3a.evemu", {"ID_INPUT_TOUCHPAD": "1"}),
    ("wacom-intuos5-touch-m-finger.desc", {"ID_INPUT_TOUCHPAD": "1"}),
    ("synaptics-touchpad.hp8470p.desc", {"ID_INPUT_TOUCHPAD": "1"}),  # no resolution
]


def _expected_frames(path: Path) -> list[dict[str, object]]:
    rec = load(path)
    desc = sizes.apply(rec.description)
    units = SurfaceUnits(desc)
    return [frame_json(units, f) for f in FrameAssembler(desc).feed_all(rec.events)]


MAX_SECONDS = 2.0  # umockdev plays at recorded pace: longer recordings are cut here


def _first_seconds(
    events: list[tuple[int, int, int, int, int]],
) -> list[tuple[int, int, int, int, int]]:
    """The events up to the first SYN_REPORT MAX_SECONDS after the start."""
    t0 = events[0][0] + events[0][1] / 1e6
    for i, (sec, usec, t, c, _) in enumerate(events):
        if t == 0 and c == 0 and sec + usec / 1e6 - t0 >= MAX_SECONDS:
            return events[: i + 1]
    return events


def _read_device(evdev_data: Path, tmp_path: Path, name: str, udev: dict[str, str]) -> None:
    rec = load(evdev_data / name)
    rec.events = _first_seconds(rec.events)
    desc = sizes.apply(rec.description)
    units = SurfaceUnits(desc)
    expected = [frame_json(units, f) for f in FrameAssembler(desc).feed_many(rec.events)]
    files = write(rec, tmp_path, udev=udev)
    cmd = stiction_cmd("evdev", "read", files.node, "--json", "--grab", "--stats")
    proc = run_under_umockdev([files], [*cmd, "--frames", str(len(expected))])
    assert proc.returncode == 0, proc.stderr
    got = [json.loads(line) for line in proc.stdout.splitlines()]
    assert got == expected
    stats = json.loads(proc.stderr.strip().splitlines()[-1])
    assert stats["events"] == len(rec.events)
    assert stats.get("syn_dropped", 0) == 0


@pytest.mark.parametrize(("name", "udev"), FAST)
def test_live_frames_equal_recording(
    evdev_data: Path, tmp_path: Path, name: str, udev: dict[str, str]
) -> None:
    _read_device(evdev_data, tmp_path, name, udev)


@pytest.mark.slow
@pytest.mark.parametrize(("name", "udev"), SLOW)
def test_live_frames_equal_recording_long(
    evdev_data: Path, tmp_path: Path, name: str, udev: dict[str, str]
) -> None:
    _read_device(evdev_data, tmp_path, name, udev)


SAMPLES_SCRIPT = textwrap.dedent(
    """
    import json, sys
    from stiction.drivers.evdev import open_device
    from stiction.drivers.source import SampleSource
    n = int(sys.argv[2])
    src = open_device(sys.argv[1], grab=True)
    assert isinstance(src, SampleSource)
    out = {"name": src.name, "kind": src.kind, "size": src.surface_size,
           "clock": src.clock, "samples": []}
    it = src.samples()
    for s in it:
        out["samples"].append([s.t, s.x, s.y, s.tip, s.in_range, s.contact, s.pressure,
                               s.tool.value, s.tilt_x, s.tilt_y, s.buttons])
        if len(out["samples"]) == n:
            break
    it.close()
    src.close()
    src.close()
    out["stats"] = src.stats()
    print(json.dumps(out))
    """
)


@pytest.mark.parametrize(("name", "udev"), FAST)
def test_live_samples_equal_replay(
    evdev_data: Path, tmp_path: Path, name: str, udev: dict[str, str]
) -> None:
    """open_device() yields the same PenSamples as replay(), times from the kernel."""
    rep = replay(evdev_data / name)
    # a live device does not end contacts at the end of the stream: compare up to there
    want = [
        [
            s.t,
            s.x,
            s.y,
            s.tip,
            s.in_range,
            s.contact,
            s.pressure,
            s.tool.value,
            s.tilt_x,
            s.tilt_y,
            s.buttons,
        ]
        for s in rep.samples()
    ]
    rec = load(evdev_data / name)
    frames = FrameAssembler(sizes.apply(rec.description)).feed_all(rec.events)
    n_live = sum(len(f.contacts) + len(f.ended) for f in frames)
    files = write(rec, tmp_path, udev=udev)
    py = stiction_cmd()[0]
    proc = run_under_umockdev([files], [py, "-c", SAMPLES_SCRIPT, files.node, str(n_live)])
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["samples"] == want[:n_live]
    assert out["kind"] == rep.kind and out["name"] == rep.name
    assert out["size"] == list(rep.surface_size or ())
    # umockdev has no EVIOCSCLOCKID: the driver says it kept the realtime clock
    assert out["clock"] == "realtime"


DISCOVER_SCRIPT = textwrap.dedent(
    """
    import json
    from stiction.drivers.evdev import discover
    print(json.dumps([[d.path, d.backend, d.vid_pid, d.name, d.kind, d.problem]
                      for d in discover()]))
    """
)


def test_discovery_lists_mocked_tablet_and_touchpad(evdev_data: Path, tmp_path: Path) -> None:
    pen = write(
        load(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu"),
        tmp_path,
        num=5,
        udev={"ID_INPUT_TABLET": "1"},
    )
    pad = write(
        load(evdev_data / "cypress-trackpad.two-finger-press.evemu"),
        tmp_path,
        num=6,
        udev={"ID_INPUT_TOUCHPAD": "1"},
    )
    proc = run_under_umockdev([pen, pad], [stiction_cmd()[0], "-c", DISCOVER_SCRIPT])
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout)
    assert found == [
        ["/dev/input/event5", "evdev", "056a:0333", "Wacom Cintiq 13HD touch Pen", "pen", None],
        ["/dev/input/event6", "evdev", "0002:0011", "CyPS/2 Cypress Trackpad", "touchpad", None],
    ]


def test_missing_node_is_a_device_error(tmp_path: Path) -> None:
    from stiction.drivers.evdev import open_device
    from stiction.errors import DeviceError

    with pytest.raises(DeviceError, match="no such input device"):
        open_device(str(tmp_path / "event99"))


# -- unplug through umockdev's GI API (system python3 controls the testbed) ---------

UNPLUG_READER = textwrap.dedent(
    """
    import json, sys
    from stiction.drivers.evdev import discover, open_device
    from stiction.errors import DeviceError
    path = sys.argv[1]
    src = open_device(path, grab=True)
    print("ready", flush=True)
    try:
        for s in src.samples():
            print(json.dumps([s.t, s.x, s.y, s.tip, s.in_range, s.contact]), flush=True)
    except DeviceError as exc:
        print(json.dumps({"error": str(exc), "stats": src.stats()}), flush=True)
    src.close()
    try:
        open_device(path)
    except DeviceError as exc:
        print(json.dumps({"reopen_failed": str(exc)}), flush=True)
    assert sys.stdin.readline() == "replugged\\n"
    # what a daemon does: find the device again by what it is, not by its old node
    (info,) = [d for d in discover() if d.name == src.description.name]
    again = open_device(info.path, grab=True)
    print(json.dumps({"reopened": again.name, "path": info.path}), flush=True)
    again.close()
    """
)


@pytest.mark.skipif(not gi_available(), reason="needs system python3 with gi + UMockdev typelib")
def test_unplug_ends_contacts_reports_error_and_device_can_be_reopened(
    evdev_data: Path, tmp_path: Path
) -> None:

    name = "wacom-cintiq-13hd-touch-pen.evemu"
    rec = load(evdev_data / name)
    # the stream stops after 40 frames with the pen in range; then the device goes away
    write_replug_pair(rec, tmp_path, 40, {"ID_INPUT_TABLET": "1"})
    out = run_controller(tmp_path, UNPLUG_READER, "40")
    lines = out["reader"]
    assert lines[0] == "ready", out
    samples = [json.loads(x) for x in lines if x.startswith("[")]
    errors = [json.loads(x) for x in lines if x.startswith('{"error"')]
    assert len(errors) == 1, out
    assert "went away" in errors[0]["error"] and "No such device" in errors[0]["error"]
    assert errors[0]["stats"]["unplugged"] == 1
    # what was read before the unplug is the recording's beginning ...
    want = [
        [s.t, s.x, s.y, s.tip, s.in_range, s.contact] for s in replay(evdev_data / name).samples()
    ]
    live, end = samples[:-1], samples[-1]
    assert len(live) == 40 and live == want[:40] and live[-1][4] is True
    # ... and the pen's contact ended where it last was, out of range, at the last kernel time
    assert end == [live[-1][0], live[-1][1], live[-1][2], False, False, 0]
    reopen = [json.loads(x) for x in lines if x.startswith('{"reopen')]
    assert "no such input device" in reopen[0]["reopen_failed"]
    assert reopen[1] == {"reopened": "wacom-cintiq-13hd-touch-pen", "path": "/dev/input/event6"}
    assert out["returncode"] == 0, out["stderr"]


CRASH_READER = textwrap.dedent(
    """
    import sys
    from stiction.drivers.evdev import open_device
    src = open_device(sys.argv[1], grab=True)
    print("ready", flush=True)
    for n, s in enumerate(src.samples()):
        if n == 5:
            raise RuntimeError("a bug in the consumer")
    """
)


@pytest.mark.skipif(not gi_available(), reason="needs system python3 with gi + UMockdev typelib")
def test_grab_is_released_when_the_consumer_crashes(evdev_data: Path, tmp_path: Path) -> None:

    write(load(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu"), tmp_path, num=5)
    out = run_controller(tmp_path, CRASH_READER, "0", "crash")
    assert "RuntimeError: a bug in the consumer" in out["stderr"]
    assert out["returncode"] == 1
    assert out["grabs"] == [1, 0]  # EVIOCGRAB 1 on open, EVIOCGRAB 0 on the way out


@pytest.mark.parametrize(
    ("name", "out"),
    [
        ("wacom-cintiq-13hd-touch-pen.evemu", "pen.yml"),
        ("cypress-trackpad.two-finger-press.evemu", "pad.evemu"),
    ],
)
def test_record_a_live_device_and_decode_it_again(
    evdev_data: Path, tmp_path: Path, name: str, out: str
) -> None:
    expected = _expected_frames(evdev_data / name)
    files = write(load(evdev_data / name), tmp_path)
    target = tmp_path / out
    cmd = stiction_cmd("evdev", "record", files.node, str(target), "--frames", str(len(expected)))
    proc = run_under_umockdev([files], cmd)
    assert proc.returncode == 0, proc.stderr
    assert f"{len(expected)} frames written" in proc.stderr
    again = _expected_frames(target)
    assert again == expected
    rec = load(target)
    assert rec.description.name == load(evdev_data / name).description.name
    assert rec.events == load(evdev_data / name).events


@pytest.mark.skipif(not gi_available(), reason="needs system python3 with gi + UMockdev typelib")
def test_syn_dropped_on_a_live_device_resyncs_from_the_kernel_state(
    evdev_data: Path, tmp_path: Path
) -> None:
    """SYN_DROPPED mid-frame: the reader re-reads keys, slot and all slots (EVIOCGMTSLOTS).

    The mocked kernel answers with the true state after the damaged frame, so
    the frame reported after the resync must equal the recording's own frame.
    """

    from evdev import ecodes as e

    name = "cypress-trackpad.two-finger-press.evemu"
    rec = load(evdev_data / name)
    expected = _expected_frames(evdev_data / name)
    syn = [i for i, ev in enumerate(rec.events) if ev[2:4] == (0, 0)]
    k = next(j for j in range(5, len(syn)) if len(expected[j]["contacts"]) == 2)
    # the true state after frame k, as the kernel would report it
    asm = FrameAssembler(rec.description)
    asm.feed_many(rec.events[: syn[k] + 1])
    codes = [e.ABS_MT_TRACKING_ID, e.ABS_MT_POSITION_X, e.ABS_MT_POSITION_Y, e.ABS_MT_PRESSURE]
    fields = ["tid", "x", "y", "pressure"]
    state = {
        "keys": sorted(asm._keys),
        "slot": asm._slot,
        "slots": {
            str(c): [getattr(s, f) for s in asm._slots] for c, f in zip(codes, fields, strict=True)
        },
    }
    # the stream loses frame k: SYN_DROPPED after its first event
    start = syn[k - 1] + 1
    sec, usec = rec.events[start][:2]
    rec.events = [
        *rec.events[: start + 1],
        (sec, usec, 0, e.SYN_DROPPED, 0),
        *rec.events[start + 1 :],
    ]
    write(rec, tmp_path, num=5)
    (tmp_path / "state.json").write_text(json.dumps(state))
    reader = textwrap.dedent(
        f"""
        import itertools, json, sys
        from stiction.drivers.evdev.cli import frame_json
        from stiction.drivers.evdev.device import DeviceSource
        src = DeviceSource(sys.argv[1])
        print("ready", flush=True)
        for f in itertools.islice(src.frames(), {len(expected)}):
            print(json.dumps(frame_json(src._units, f)), flush=True)
        print(json.dumps({{"stats": src.stats()}}), flush=True)
        src.close()
        """
    )
    out = run_controller(tmp_path, reader, "0", "run")
    assert out["returncode"] == 0, out["stderr"]
    lines = [json.loads(x) for x in out["reader"][1:]]
    stats = lines.pop()["stats"]
    assert stats["syn_dropped"] == 1 and stats["resyncs"] == 1
    assert stats.get("resync_failed_slots", 0) == 0 and stats.get("resync_failed_keys", 0) == 0
    assert stats["events_discarded"] == syn[k] - start  # all of frame k's events
    assert lines == expected  # frame k itself comes back from the re-read state


CLOSE_SCRIPT = textwrap.dedent(
    """
    import sys, threading
    from stiction.drivers.evdev import open_device
    src = open_device(sys.argv[1], grab=True)
    got, first = [], threading.Event()
    def consume():
        for s in src.samples():
            got.append(s)
            first.set()
    th = threading.Thread(target=consume)
    th.start()
    assert first.wait(20), "no sample arrived"
    src.close()
    th.join(20)
    print("stopped" if not th.is_alive() else "still running", len(got) > 0)
    """
)


def test_close_from_another_thread_stops_a_blocked_reader(evdev_data: Path, tmp_path: Path) -> None:
    rec = load(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu")
    rec.events = rec.events[:60]  # a few frames, then silence: the reader blocks in select()
    files = write(rec, tmp_path)
    proc = run_under_umockdev([files], [stiction_cmd()[0], "-c", CLOSE_SCRIPT, files.node])
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["stopped", "True"]


def test_samples_of_a_device_without_size_is_a_clear_error(
    evdev_data: Path, tmp_path: Path
) -> None:
    files = write(load(evdev_data / "synaptics-touchpad.hp8470p.desc"), tmp_path)
    script = (
        "import sys\nfrom stiction.drivers.evdev import open_device\n"
        "from stiction.errors import DeviceError\n"
        "try:\n    open_device(sys.argv[1])\n"
        "except DeviceError as e:\n    print(e)\n"
    )
    proc = run_under_umockdev([files], [stiction_cmd()[0], "-c", script, files.node])
    assert proc.returncode == 0, proc.stderr
    assert "SynPS/2 Synaptics TouchPad" in proc.stdout and "no resolution" in proc.stdout


def test_describe_a_live_device(evdev_data: Path, tmp_path: Path) -> None:
    files = write(load(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu"), tmp_path)
    proc = run_under_umockdev([files], stiction_cmd("evdev", "describe", files.node, "--json"))
    assert proc.returncode == 0, proc.stderr
    info = json.loads(proc.stdout)
    assert info["name"] == "Wacom Cintiq 13HD touch Pen" and info["kind"] == "pen"
    assert info["size_source"] == "kernel"
    assert info["size_m"] == pytest.approx([(59152 - 400) / 200 / 1000, (33448 - 400) / 200 / 1000])
    assert info["axes"]["ABS_TILT_X"] == [-64, 63, 57.0]


CHOPPED_READ_SCRIPT = textwrap.dedent(
    """
    import itertools, json, os, sys
    real_read = os.read
    os.read = lambda fd, n: real_read(fd, min(n, 37))  # every read ends mid-event
    from stiction.drivers.evdev.cli import frame_json
    from stiction.drivers.evdev.device import DeviceSource
    src = DeviceSource(sys.argv[1])
    frames = [frame_json(src._units, f) for f in itertools.islice(src.frames(), int(sys.argv[2]))]
    print(json.dumps({"frames": frames, "stats": src.stats()}))
    src.close()
    """
)


def test_reads_that_end_mid_event_do_not_misframe(evdev_data: Path, tmp_path: Path) -> None:
    expected = _expected_frames(evdev_data / "cypress-trackpad.two-finger-press.evemu")
    files = write(load(evdev_data / "cypress-trackpad.two-finger-press.evemu"), tmp_path)
    argv = [stiction_cmd()[0], "-c", CHOPPED_READ_SCRIPT, files.node, str(len(expected))]
    proc = run_under_umockdev([files], argv)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["frames"] == expected
    assert out["stats"]["partial_reads"] > 100 and out["stats"]["events"] == 278
