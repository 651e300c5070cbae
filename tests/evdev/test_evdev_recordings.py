"""Every shared evdev recording decodes, and what it decodes to is right."""

from __future__ import annotations

from pathlib import Path

import pytest

from stiction.drivers.evdev import replay, sizes
from stiction.drivers.evdev.frames import FrameAssembler
from stiction.drivers.evdev.recording import load
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import Tool
from stiction.errors import DeviceError, RecordingError

# (file, kind, frames, contacts seen) counted independently from the files:
# frames = number of SYN_REPORT lines; ids = distinct ABS_MT_TRACKING_ID >= 0.
RECORDINGS = [
    ("wacom-cintiq-13hd-touch-pen.evemu", "pen", 79),
    ("wacom-cintiq-12wx.evemu", "pen", 362),
    ("wacom-intuos4-6x9.desc", "pen", 361),
    ("uc-logic-wp5540u-pen.evemu", "pen", 506),
    ("wacom-cintiq-13hd-touch-finger.evemu", "touchscreen", 5),
    ("cypress-trackpad.two-finger-press.evemu", "touchpad", 37),
    ("elantech-touchpad.samsung-700z3a.evemu", "touchpad", 297),
    ("synaptics-touchpad.hp8470p.desc", "touchpad", 150),
    ("wacom-intuos5-touch-m-finger.desc", "touchpad", 123),
]


def _events_text(path: Path) -> list[list[str]]:
    rec = load(path)
    lines = rec.events_path.read_text().splitlines()
    return [ln.split("#")[0].split() for ln in lines if ln.startswith("E:")]


@pytest.mark.parametrize(("name", "kind", "frames"), RECORDINGS)
def test_recording_decodes(evdev_data: Path, name: str, kind: str, frames: int) -> None:
    rec = load(evdev_data / name)
    desc = sizes.apply(rec.description)
    assert desc.kind == kind
    asm = FrameAssembler(desc)
    out = asm.feed_all(rec.events)
    assert len(out) == frames
    raw = _events_text(evdev_data / name)
    assert len(rec.events) == len(raw)
    syn_times = [
        (int(f[1].split(".")[0]), int(f[1].split(".")[1]))
        for f in raw
        if f[2] == "0000" and f[3] == "0000"
    ]
    assert [(f.sec, f.usec) for f in out] == syn_times
    assert asm.stats["syn_dropped"] == 0


def _tracking_ids(raw: list[list[str]]) -> list[int]:
    return [int(f[4]) for f in raw if f[2] == "0003" and f[3] == "0039"]


@pytest.mark.parametrize(
    "name",
    [n for n, k, _ in RECORDINGS if k != "pen"],
)
def test_contacts_follow_tracking_ids(evdev_data: Path, name: str) -> None:
    """Each tracking id >= 0 begins a contact; each contact ends exactly once."""
    rec = load(evdev_data / name)
    out = FrameAssembler(sizes.apply(rec.description)).feed_all(rec.events)
    started = [i for i in _tracking_ids(_events_text(evdev_data / name)) if i >= 0]
    seen: list[int] = []
    ended: list[int] = []
    active: set[int] = set()
    for f in out:
        ids = {c.id for c in f.contacts}
        for c in f.ended:
            assert c.id in active and not c.in_range and not c.tip
            ended.append(c.id)
        for i in ids - active:
            seen.append(i)
        active = ids
        assert all(c.tracking_id == c.id and c.slot is not None for c in f.contacts)
    assert seen == started
    # everything that started has ended, or is still down at the end of the recording
    assert sorted(ended + sorted(active)) == sorted(started)


@pytest.mark.parametrize(("name", "kind", "frames"), RECORDINGS)
def test_positions_in_range(evdev_data: Path, name: str, kind: str, frames: int) -> None:
    rec = load(evdev_data / name)
    desc = sizes.apply(rec.description)
    units = SurfaceUnits(desc)
    xa, ya = units.x_axis, units.y_axis
    # The Synaptics firmware reports X down to 1298 (min 1472) and Y one past its max.
    slack = 200 if name.startswith("synaptics") else 0
    n = 0
    for f in FrameAssembler(desc).feed_all(rec.events):
        for c in f.contacts:
            n += 1
            assert xa.minimum - slack <= c.x <= xa.maximum + slack
            assert ya.minimum - slack <= c.y <= ya.maximum + slack
            p = units.pressure(c.pressure)
            assert p is None or 0.0 <= p <= 1.0
            if units.surface_size is not None:
                w, h = units.surface_size
                xm, ym = units.x_m(c.x), units.y_m(c.y)
                assert xm is not None and ym is not None
                assert -slack / 10 <= xm * 1000 <= w * 1000 and 0 <= ym <= h
    assert n > 0


def test_synaptics_x_below_min_is_kept_and_counted(evdev_data: Path) -> None:
    rec = load(evdev_data / "synaptics-touchpad.hp8470p.desc")
    asm = FrameAssembler(rec.description)
    xs = [c.x for f in asm.feed_all(rec.events) for c in f.contacts]
    assert min(xs) == 1298 < rec.description.axes[0].minimum
    assert asm.stats["value_out_of_range"] > 0


def test_pen_end_keeps_last_position_not_zeroed_axes(evdev_data: Path) -> None:
    """Wacom zeroes X/Y with BTN_TOOL_PEN 0; the end sample stays where the pen was."""
    rec = load(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu")
    frames = FrameAssembler(rec.description).feed_all(rec.events)
    ends = [(i, c) for i, f in enumerate(frames) for c in f.ended]
    assert len(ends) == 1
    i, c = ends[0]
    assert frames[i].contacts == ()
    prev = frames[i - 1].contacts[0]
    assert (c.x, c.y) == (prev.x, prev.y) and c.x >= 400


def test_eraser_is_reported(evdev_data: Path) -> None:
    src = replay(evdev_data / "wacom-cintiq-12wx.evemu")
    tools = {s.tool for s in src.samples()}
    assert tools == {Tool.PEN, Tool.ERASER}


def test_tilt_in_degrees(evdev_data: Path) -> None:
    # Cintiq 13HD: resolution 57 units/radian -> value 19 = 19.1 degrees
    src = replay(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu")
    first = next(iter(src.samples()))
    assert first.tilt_x == pytest.approx(19 / 57 * 180 / 3.141592653589793)
    assert first.tilt_y == pytest.approx(32 / 57 * 180 / 3.141592653589793)
    # Intuos4 on an old kernel: 0..127 and no resolution -> +-64 degrees around 63.5
    src = replay(evdev_data / "wacom-intuos4-6x9.desc")
    for s in src.samples():
        assert s.tilt_x is not None and -64.0 <= s.tilt_x <= 64.0


def test_replay_samples_end_every_contact(evdev_data: Path) -> None:
    src = replay(evdev_data / "uc-logic-wp5540u-pen.evemu")
    samples = list(src.samples())
    assert samples[-1].in_range is False and samples[-1].tip is False
    assert all(s.in_range for s in samples[:-1])
    assert src.kind == "pen" and src.name == "uc-logic-tablet-wp5540u-pen"
    w, h = src.surface_size or (0, 0)
    assert w == pytest.approx(32767 / 235 / 1000) and h == pytest.approx(32767 / 323 / 1000)
    assert src.stats()["frames"] == 506
    assert [s.t for s in samples] == sorted(s.t for s in samples)


def test_device_table_supplies_missing_resolution(evdev_data: Path) -> None:
    src = replay(evdev_data / "wacom-intuos4-6x9.desc")
    assert src.surface_size == pytest.approx((0.22352, 0.13970))
    src = replay(evdev_data / "wacom-intuos5-touch-m-finger.double-center-scroll.events")
    assert src.surface_size == pytest.approx((0.22352, 0.13970))


def test_no_resolution_needs_a_size(evdev_data: Path) -> None:
    path = evdev_data / "synaptics-touchpad.hp8470p.desc"
    with pytest.raises(DeviceError, match=r"SynPS/2 Synaptics TouchPad.*no resolution"):
        replay(path)
    src = replay(path, size_mm=(100.0, 60.0))
    assert src.surface_size == pytest.approx((0.1, 0.06))
    xs = [s.x for s in src.samples()]
    assert min(xs) == 0.0 and 0 < max(xs) <= 0.1  # the firmware's below-min X is clamped
    assert src.stats()["value_out_of_range"] > 0


def test_missing_partner_file_is_a_clear_error(tmp_path: Path, evdev_data: Path) -> None:
    desc = tmp_path / "x.desc"
    desc.write_bytes((evdev_data / "synaptics-touchpad.hp8470p.desc").read_bytes())
    with pytest.raises(RecordingError, match=r"no matching \.events"):
        load(desc)
    (tmp_path / "x.a.events").write_text("E: 0.1 0000 0000 0\n")
    (tmp_path / "x.b.events").write_text("E: 0.1 0000 0000 0\n")
    with pytest.raises(RecordingError, match="several candidates"):
        load(desc)
    assert len(load(desc, tmp_path / "x.a.events").events) == 1


class VirtualClock:
    """Time that moves only when the replay waits: pacing without sleeping."""

    def __init__(self) -> None:
        self.now = 100.0
        self.waits: list[float] = []

    def clock(self) -> float:
        return self.now

    def wait(self, seconds: float) -> bool:
        self.waits.append(seconds)
        self.now += seconds
        return False


def test_realtime_replay_waits_for_recorded_times(evdev_data: Path) -> None:
    from stiction.drivers.evdev.playback import ReplaySource
    from stiction.drivers.evdev.recording import load as load_rec

    vc = VirtualClock()
    src = ReplaySource(
        load_rec(evdev_data / "cypress-trackpad.two-finger-press.evemu"),
        realtime=True,
        clock=vc.clock,
        wait=vc.wait,
    )
    seen = []
    for s in src.samples():
        seen.append((vc.now - 100.0, s.t))
    t0 = seen[0][1]
    for wall, t in seen:
        assert wall == pytest.approx(t - t0, abs=1e-9)  # each frame waits until its time
    assert sum(vc.waits) == pytest.approx(seen[-1][1] - t0)
    fast = replay(evdev_data / "cypress-trackpad.two-finger-press.evemu", realtime=False)
    assert [s.t for s in fast.samples()] == [t for _, t in seen]


def test_close_stops_a_blocked_realtime_replay(evdev_data: Path) -> None:
    import threading

    src = replay(evdev_data / "elantech-touchpad.samsung-700z3a.evemu", realtime=True)
    got: list[float] = []
    first = threading.Event()

    def consume() -> None:
        for s in src.samples():
            got.append(s.t)
            first.set()

    th = threading.Thread(target=consume)
    th.start()
    assert first.wait(10)
    src.close()
    src.close()  # idempotent
    th.join(10)
    assert not th.is_alive()
    assert 0 < len(got) < 200  # 7.4 s of recording; stopped long before its end


def test_package_replay_factory_survives_submodule_import(evdev_data: Path) -> None:
    """`stiction.drivers.evdev.replay(...)` is the contract even after the submodule loads."""
    import importlib

    import stiction.drivers.evdev as pkg

    importlib.import_module("stiction.drivers.evdev.playback")
    src = pkg.replay(evdev_data / "cypress-trackpad.two-finger-press.evemu", None, False)
    assert src.kind == "touchpad" and len(list(src.samples())) == 69


def test_discovery_from_sysfs_reports_problems(tmp_path: Path) -> None:
    """Classification from sysfs bits alone, and the reason a node cannot be used."""
    from stiction.drivers.evdev.discovery import discover

    def node(n: int, name: str, key: str, abs_: str, props: str) -> None:
        dev = tmp_path / f"event{n}" / "device"
        (dev / "id").mkdir(parents=True)
        (dev / "capabilities").mkdir()
        (dev / "name").write_text(name + "\n")
        (dev / "properties").write_text(props + "\n")
        for f, v in (("bustype", "0003"), ("vendor", "056a"), ("product", "0333")):
            (dev / "id" / f).write_text(v + "\n")
        (dev / "id" / "version").write_text("0110\n")
        (dev / "capabilities" / "key").write_text(key + "\n")
        (dev / "capabilities" / "abs").write_text(abs_ + "\n")

    def mask(*bits: int) -> str:  # sysfs: hex longs, most significant first
        words = [0] * (max(bits) // 64 + 1)
        for b in bits:
            words[b // 64] |= 1 << (b % 64)
        return " ".join(f"{w:x}" for w in reversed(words))

    node(3, "Keyboard", mask(*range(1, 120)), "0", "0")  # no axes: not listed
    node(5, "Wacom Pen", mask(0x140, 0x141, 0x14A, 0x14B), mask(0, 1, 24, 26, 27), "2")
    mt = (0, 1, 24, 47, 53, 54, 57, 58)
    node(12, "Touchpad", mask(272, 325, 330, 333), mask(*mt), mask(0, 2))
    found = discover(tmp_path)
    assert [(d.path, d.kind, d.vid_pid) for d in found] == [
        ("/dev/input/event5", "pen", "056a:0333"),
        ("/dev/input/event12", "touchpad", "056a:0333"),
    ]
    assert all(d.problem is not None and "does not exist" in d.problem for d in found)


@pytest.mark.parametrize("what", ["file", "dir", "null"])
def test_opening_something_that_is_not_an_event_node(tmp_path: Path, what: str) -> None:
    from stiction.drivers.evdev import open_device

    target = {"file": tmp_path / "x", "dir": tmp_path, "null": Path("/dev/null")}[what]
    if what == "file":
        target.write_text("not a device")
    with pytest.raises(DeviceError, match=r"not an evdev input device|directory"):
        open_device(str(target))
