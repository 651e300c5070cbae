"""Event nodes stiction has never seen: whole classes of capability sets.

Each class is written as the evemu file a user would record of such a node
and read through `replay`, the path a recording takes into the daemon (the
live node takes the same description through `sizes.apply`/`require`; the
umockdev test at the end runs the live python-evdev path for the classes
that decide what `stiction devices` lists). The expectation is the brief's:
the node is read sensibly, or refused with one line that names it and says
what to do -- never a traceback, never a silent wrong size.
"""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path
from typing import Any

import pytest
from evdev import ecodes as e
from evdev_mockfiles import (
    gi_available,
    run_controller,
    run_under_umockdev,
    stiction_cmd,
    umockdev_available,
    write,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stiction.cli import main
from stiction.drivers.evdev import evemu, replay, sizes
from stiction.drivers.evdev.description import AbsAxis, DeviceDescription
from stiction.drivers.evdev.device import live_reader_for, new_assembler
from stiction.drivers.evdev.frames import INPUT_EVENT
from stiction.drivers.evdev.recording import Recording, load
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.errors import DeviceError, RecordingError, SizeUnknown

Event = tuple[int, int, int, int, int]
PEN_KEYS = frozenset({e.BTN_TOOL_PEN, e.BTN_TOUCH, e.BTN_STYLUS})


def ax(lo: int, hi: int, res: float = 0) -> AbsAxis:
    return AbsAxis(0, lo, hi, 0, 0, res)


def pen_axes(**extra: AbsAxis) -> dict[int, AbsAxis]:
    axes = {e.ABS_X: ax(0, 10000, 40), e.ABS_Y: ax(0, 6000, 40), e.ABS_PRESSURE: ax(0, 1023)}
    axes.update({getattr(e, k): v for k, v in extra.items()})
    return axes


def mt_axes(slots: int) -> dict[int, AbsAxis]:
    return {
        e.ABS_MT_SLOT: ax(0, slots - 1),
        e.ABS_MT_TRACKING_ID: ax(0, 65535),
        e.ABS_MT_POSITION_X: ax(0, 4000, 10),
        e.ABS_MT_POSITION_Y: ax(0, 3000, 10),
    }


def device(
    name: str, keys: frozenset[int], axes: dict[int, AbsAxis], *props: int
) -> DeviceDescription:
    return DeviceDescription(name, 3, 0x056A, 0x0374, 0, frozenset(props), keys, axes)


def pen_stroke(x: int = 500, y: int = 400) -> list[Event]:
    """Pen in, three moves on the surface, pen out."""
    ev: list[Event] = [(1, 0, e.EV_KEY, e.BTN_TOOL_PEN, 1), (1, 0, e.EV_KEY, e.BTN_TOUCH, 1)]
    for i in range(3):
        ev += [(1, i * 5000, e.EV_ABS, e.ABS_X, x + i), (1, i * 5000, e.EV_ABS, e.ABS_Y, y)]
        ev += [(1, i * 5000, e.EV_ABS, e.ABS_PRESSURE, 300), (1, i * 5000, 0, 0, 0)]
    return [
        *ev,
        (1, 20000, e.EV_KEY, e.BTN_TOUCH, 0),
        (1, 20000, e.EV_KEY, e.BTN_TOOL_PEN, 0),
        (1, 20000, 0, 0, 0),
    ]


def finger_stroke(slot: int = 0) -> list[Event]:
    ev: list[Event] = [
        (1, 0, e.EV_ABS, e.ABS_MT_SLOT, slot),
        (1, 0, e.EV_ABS, e.ABS_MT_TRACKING_ID, 7),
    ]
    for i in range(3):
        ev += [(1, i * 5000, e.EV_ABS, e.ABS_MT_POSITION_X, 100 + i)]
        ev += [(1, i * 5000, e.EV_ABS, e.ABS_MT_POSITION_Y, 200), (1, i * 5000, 0, 0, 0)]
    return [*ev, (1, 20000, e.EV_ABS, e.ABS_MT_TRACKING_ID, -1), (1, 20000, 0, 0, 0)]


def recorded(tmp_path: Path, desc: DeviceDescription, events: list[Event]) -> Path:
    path = tmp_path / "device.evemu"
    path.write_text(evemu.describe(desc) + evemu.write_events(events))
    return path


# -- refused, with the reason that applies -----------------------------------------

WACOM_PAD = device(
    "Wacom Intuos S Pad",
    frozenset({e.BTN_0, e.BTN_1, e.BTN_2, e.BTN_3, e.BTN_STYLUS}),
    {e.ABS_X: ax(0, 1), e.ABS_Y: ax(0, 1), e.ABS_WHEEL: ax(0, 71), e.ABS_MISC: ax(0, 0)},
)

REFUSED = {
    # the kernel's wacom pad node: ABS_X/Y 0..1 and BTN_STYLUS for old programs, and
    # the catalogue knows the tablet's pen area (152 x 95 mm) for its vid:pid: it was
    # read as a pen on that area
    "button pad": (WACOM_PAD, "button pad"),
    "protocol A only": (
        device(
            "Acme TS",
            frozenset({e.BTN_TOUCH}),
            {e.ABS_MT_POSITION_X: ax(0, 4000, 10), e.ABS_MT_POSITION_Y: ax(0, 3000, 10)},
            e.INPUT_PROP_DIRECT,
        ),
        "protocol A",
    ),
    "a slot axis with no slot": (
        device(
            "Acme TS",
            frozenset({e.BTN_TOUCH}),
            {**mt_axes(1), e.ABS_MT_SLOT: ax(0, -1)},
            e.INPUT_PROP_DIRECT,
        ),
        "protocol A",
    ),
    "X range min == max": (
        device("Acme Pen", PEN_KEYS, pen_axes(ABS_X=ax(100, 100, 40))),
        "empty X range (ABS_X 100..100)",
    ),
    "Y range min > max": (
        device("Acme Pen", PEN_KEYS, pen_axes(ABS_Y=ax(6000, 0, 40))),
        "empty Y range (ABS_Y 6000..0)",
    ),
    "MT X range inverted": (
        device(
            "Acme TP",
            frozenset({e.BTN_TOUCH, e.BTN_TOOL_FINGER}),
            {**mt_axes(5), e.ABS_MT_POSITION_X: ax(4000, 0, 10)},
        ),
        "empty X range (ABS_MT_POSITION_X 4000..0)",
    ),
    # X/Y and no key that touches: measuring it would not make it a surface
    "joystick": (
        device(
            "Acme Stick",
            frozenset({e.BTN_TRIGGER, e.BTN_THUMB}),
            {e.ABS_X: ax(-127, 127), e.ABS_Y: ax(-127, 127)},
        ),
        "not a pen, touchpad or touchscreen: it has X/Y axes but no touch",
    ),
    "virtual machine's absolute pointer": (
        device(
            "QEMU USB Tablet",
            frozenset({e.BTN_LEFT, e.BTN_RIGHT}),
            {e.ABS_X: ax(0, 32767), e.ABS_Y: ax(0, 32767)},
        ),
        "(a joystick, or an absolute pointer)",
    ),
    "no Y axis": (
        device("Acme Pen", PEN_KEYS, {e.ABS_X: ax(0, 1000, 10)}),
        "no X/Y position axes",
    ),
}


@pytest.mark.parametrize("case", list(REFUSED))
def test_a_node_no_size_can_fix_is_refused_with_its_reason(tmp_path: Path, case: str) -> None:
    desc, reason = REFUSED[case]
    path = recorded(tmp_path, desc, [(1, 0, 0, 0, 0)])
    for size in (None, (100.0, 60.0)):  # a size given changes nothing: it is not the problem
        with pytest.raises(DeviceError) as info:
            replay(path, size_mm=size)
        msg = str(info.value)
        assert reason in msg and repr(desc.name) in msg and "\n" not in msg
        assert not isinstance(info.value, SizeUnknown)  # no one is sent measuring


def test_the_pad_is_not_listed_as_a_pen_by_its_bits_or_its_udev_tags() -> None:
    assert WACOM_PAD.kind == "other"
    tagged = DeviceDescription(
        "Wacom Intuos Pro M Pad",
        keys=frozenset({e.BTN_0, e.BTN_STYLUS}),
        axes={e.ABS_X: ax(0, 1), e.ABS_Y: ax(0, 1)},
        udev={"ID_INPUT": "1", "ID_INPUT_TABLET": "1", "ID_INPUT_TABLET_PAD": "1"},
    )
    assert tagged.kind == "other" and tagged.is_pad
    # the old kernels' single node with pad buttons and the pen (the Intuos4
    # recording) and a UC-Logic pen without tool bits stay pens
    assert device("Intuos4", PEN_KEYS | {e.BTN_0}, pen_axes()).kind == "pen"
    uclogic = device("UC-Logic", frozenset({e.BTN_STYLUS, e.BTN_TOUCH, e.BTN_0}), pen_axes())
    assert uclogic.kind == "pen" and not uclogic.is_pad


@pytest.mark.parametrize("case", ["button pad", "Y range min > max", "protocol A only"])
def test_describe_says_why_and_gives_no_size(
    tmp_path: Path, case: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`stiction evdev describe` printed the inverted range's negative width as its
    size (from the kernel); it now gives none and the reason opening would give."""
    desc, reason = REFUSED[case]
    path = recorded(tmp_path, desc, [(1, 0, 0, 0, 0)])
    assert main(["evdev", "describe", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["size_m"] is None and info["size_source"] is None
    assert reason in info["problem"]
    assert main(["evdev", "describe", str(path)]) == 0
    assert f"note: {info['problem']}" in capsys.readouterr().out


# -- asked for a size, saying why the node's own does not count --------------------

ASKED = {
    "no resolution": (pen_axes(ABS_X=ax(0, 10000), ABS_Y=ax(0, 6000)), "reports no resolution"),
    "resolution on X only": (pen_axes(ABS_Y=ax(0, 6000)), "on one axis only (X 40, Y 0"),
    "resolution 2^31-1": (
        pen_axes(ABS_X=ax(0, 10000, 2**31 - 1), ABS_Y=ax(0, 6000, 2**31 - 1)),
        "which no device has",
    ),
    "resolution 1 on a 2^32 range": (
        pen_axes(ABS_X=ax(-(2**31), 2**31 - 1, 1)),
        "4.29497e+09 x 150 mm surface",
    ),
    "negative resolution": (
        pen_axes(ABS_X=ax(0, 10000, -40), ABS_Y=ax(0, 6000, -40)),
        "no resolution",
    ),
}


@pytest.mark.parametrize("case", list(ASKED))
def test_a_node_without_a_believable_size_asks_for_one_and_says_why(
    tmp_path: Path, case: str
) -> None:
    axes, reason = ASKED[case]
    desc = DeviceDescription("Acme Pen", 3, 0x1234, 0x0001, 0, frozenset(), PEN_KEYS, axes)
    path = recorded(tmp_path, desc, pen_stroke())
    with pytest.raises(SizeUnknown) as info:
        replay(path)
    assert reason in str(info.value) and "'Acme Pen' (1234:0001)" in str(info.value)
    # and with the size the user then gives, the node is read on that surface
    samples = list(replay(path, size_mm=(250.0, 150.0)).samples())
    assert samples and all(0 <= s.x <= 0.25 and 0 <= s.y <= 0.15 for s in samples)


# -- read sensibly ------------------------------------------------------------------


def _read(tmp_path: Path, desc: DeviceDescription, events: list[Event]) -> list[object]:
    src = replay(recorded(tmp_path, desc, events))
    return list(src.samples())


def test_a_pen_whose_only_tool_is_an_airbrush_is_a_pen(tmp_path: Path) -> None:
    keys = frozenset({e.BTN_TOOL_AIRBRUSH, e.BTN_TOUCH})
    desc = device("Acme Airbrush", keys, pen_axes())
    assert desc.kind == "pen"  # was "touchpad": X/Y and BTN_TOUCH without INPUT_PROP_DIRECT
    events = [(1, 0, e.EV_KEY, e.BTN_TOOL_AIRBRUSH, 1), *pen_stroke()[1:-2]]
    events += [(1, 20000, e.EV_KEY, e.BTN_TOOL_AIRBRUSH, 0), (1, 20000, 0, 0, 0)]
    samples = _read(tmp_path, desc, events)
    assert [s.tool.value for s in samples] == ["pen"] * 4  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    ("props", "kind"),
    [
        ((e.INPUT_PROP_DIRECT,), "touchscreen"),
        ((e.INPUT_PROP_POINTER,), "touchpad"),
        ((), "touchpad"),
    ],
)
def test_a_single_touch_node_with_finger_tools_is_a_screen_only_when_direct(
    props: tuple[int, ...], kind: str
) -> None:
    """systemd's input_id: finger tool bits make a touchpad only without INPUT_PROP_DIRECT
    (a direct one was read as a touchpad, so mapped as one)."""
    keys = frozenset({e.BTN_TOUCH, e.BTN_TOOL_FINGER, e.BTN_TOOL_DOUBLETAP})
    axes = {e.ABS_X: ax(0, 4000, 10), e.ABS_Y: ax(0, 3000, 10)}
    assert device("Acme", keys, axes, *props).kind == kind


@pytest.mark.parametrize("slots", [1, 64, 1024])
def test_protocol_b_reads_one_slot_and_many(tmp_path: Path, slots: int) -> None:
    desc = device("Acme TP", frozenset({e.BTN_TOUCH, e.BTN_TOOL_FINGER}), mt_axes(slots))
    samples = _read(tmp_path, desc, finger_stroke(slot=slots - 1))
    assert [(s.contact, s.in_range) for s in samples] == [(7, True)] * 3 + [(7, False)]  # type: ignore[attr-defined]
    assert samples[0].x == pytest.approx(0.010)  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    ("x_axis", "x_value", "x_m"),
    [
        (ax(-5000, 5000, 40), 0, 0.125),  # negative minimum: metres count from it
        (ax(-(2**31), 2**31 - 1, 10**7), 0, 2**31 / 1e10),  # the whole int32 range
    ],
)
def test_negative_and_int32_wide_ranges_count_from_their_minimum(
    tmp_path: Path, x_axis: AbsAxis, x_value: int, x_m: float
) -> None:
    desc = device("Acme Pen", PEN_KEYS, pen_axes(ABS_X=x_axis))
    samples = _read(tmp_path, desc, pen_stroke(x=x_value))
    assert samples[0].x == pytest.approx(x_m, rel=1e-9)  # type: ignore[attr-defined]


TILT_CASES = [
    # (axis, raw, degrees): the kernel's units/radian where believable
    (ax(-64, 63, 57), 19, math.degrees(19 / 57)),  # Wacom Cintiq 13HD
    (ax(-90, 90, 57), 90, math.degrees(90 / 57)),  # HID -90..90 deg: 90.5 after rounding
    (ax(0, 127, 0), 127, 64.0),  # old kernels: no resolution, +-64 around the middle
    (ax(-9000, 9000, 1), 9000, 64.0),  # 1 unit/rad on +-9000: 515,662 degrees claimed
    (ax(-60, 60, 0), 60, 64.0),  # no resolution: libinput's +-64 for any range
]


@pytest.mark.parametrize(("axis", "raw", "degrees"), TILT_CASES)
def test_tilt_is_the_kernels_units_per_radian_only_where_a_pen_can_lean_that_far(
    axis: AbsAxis, raw: int, degrees: float
) -> None:
    desc = device("Acme Pen", PEN_KEYS, pen_axes(ABS_TILT_X=axis, ABS_TILT_Y=axis))
    units = SurfaceUnits(desc)
    assert units._tilt_x is not None
    assert units._tilt_x(raw) == pytest.approx(degrees)


# -- any capability set: never a traceback, never a sample off the surface ---------

_KEYS = [
    e.BTN_TOOL_PEN, e.BTN_TOOL_RUBBER, e.BTN_TOOL_AIRBRUSH, e.BTN_TOOL_MOUSE, e.BTN_TOOL_LENS,
    e.BTN_TOOL_FINGER, e.BTN_TOOL_DOUBLETAP, e.BTN_TOUCH, e.BTN_STYLUS, e.BTN_0, e.BTN_LEFT,
]  # fmt: skip
_ABS = [
    e.ABS_X, e.ABS_Y, e.ABS_PRESSURE, e.ABS_TILT_X, e.ABS_TILT_Y, e.ABS_DISTANCE,
    e.ABS_MT_SLOT, e.ABS_MT_TRACKING_ID, e.ABS_MT_POSITION_X, e.ABS_MT_POSITION_Y,
    e.ABS_MT_PRESSURE, e.ABS_MT_TOOL_TYPE,
]  # fmt: skip
_INT32 = st.one_of(st.sampled_from([0, 1, -1, 2**31 - 1, -(2**31)]), st.integers(-70000, 70000))
_RES = st.sampled_from([0, 0, 1, 5, 40, 57, 200, 2**31 - 1, -3])


@st.composite
def capability_sets(draw: st.DrawFn) -> tuple[DeviceDescription, list[Event]]:
    keys = frozenset(draw(st.sets(st.sampled_from(_KEYS))))
    axes = {
        code: AbsAxis(0, draw(_INT32), draw(_INT32), 0, 0, draw(_RES))
        for code in draw(st.sets(st.sampled_from(_ABS), min_size=1))
    }
    props = frozenset(draw(st.sets(st.sampled_from([e.INPUT_PROP_DIRECT, e.INPUT_PROP_POINTER]))))
    desc = DeviceDescription("Acme Any", 3, 0x1234, 0x0002, 0, props, keys, axes)
    ev_keys = st.tuples(st.just(e.EV_KEY), st.sampled_from(_KEYS), st.integers(0, 1))
    ev_abs = st.tuples(st.just(e.EV_ABS), st.sampled_from(_ABS), _INT32)
    body = draw(st.lists(st.one_of(ev_keys, ev_abs, st.just((0, 0, 0))), max_size=40))
    return desc, [(1, i, t, c, v) for i, (t, c, v) in enumerate(body)] + [(1, 99, 0, 0, 0)]


@settings(
    max_examples=150, deadline=None, derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)  # fmt: skip
@given(case=capability_sets(), size=st.sampled_from([None, (120.0, 80.0)]))
def test_any_capability_set_is_read_on_its_surface_or_refused_in_one_line(
    tmp_path: Path, case: tuple[DeviceDescription, list[Event]], size: tuple[float, float] | None
) -> None:
    desc, events = case
    try:
        src = replay(recorded(tmp_path, desc, events), size_mm=size)
    except (DeviceError, RecordingError) as exc:
        assert "\n" not in str(exc) and "'Acme Any'" in str(exc)
        return
    w, h = src.surface_size or (math.nan, math.nan)
    assert 1e-3 <= w <= 10 and 1e-3 <= h <= 10  # the sizes.plausible bounds, or the one given
    for s in src.samples():
        assert 0 <= s.x <= w and 0 <= s.y <= h
        assert s.pressure is None or 0 <= s.pressure <= 1
        for tilt in (s.tilt_x, s.tilt_y):
            # 90 degrees with the kernel's rounding of units/radian (resolution
            # 1 allows 135); values sent beyond the range are clamped to it
            assert tilt is None or abs(tilt) <= 135.0


@pytest.mark.parametrize("path", ["replay", "live"])
def test_a_tilt_sent_beyond_its_range_stays_within_the_range(tmp_path: Path, path: str) -> None:
    """Clamped to the range's end, as positions are to the surface: the replay's
    compiled loop and the live reader generated for the device alike."""
    desc = device("Acme Pen", PEN_KEYS, pen_axes(ABS_TILT_X=ax(-60, 60), ABS_TILT_Y=ax(-60, 60)))
    events = pen_stroke()
    events.insert(2, (1, 0, e.EV_ABS, e.ABS_TILT_X, 3000))  # firmware garbage
    events.insert(3, (1, 0, e.EV_ABS, e.ABS_TILT_Y, -3000))
    if path == "replay":
        samples: list[Any] = _read(tmp_path, desc, events)
    else:
        sized = sizes.apply(desc, (120.0, 80.0))
        reader = live_reader_for(new_assembler(sized), SurfaceUnits(sized))
        reads = [b"".join(INPUT_EVENT.pack(*ev) for ev in events)]
        samples = list(reader.samples(reads))
    tilts = [(s.tilt_x, s.tilt_y) for s in samples if s.tilt_x is not None]
    assert tilts and tilts[0] == (64.0, -64.0)  # no resolution: libinput's +-64 degrees
    assert all(abs(v) <= 64.0 for pair in tilts for v in pair)


# -- the live path: python-evdev against umockdev-mocked nodes -----------------------

LIVE_SCRIPT = textwrap.dedent(
    """
    import json, sys
    from stiction.drivers.discovery import evdev_size
    from stiction.drivers.evdev import discover, open_device
    from stiction.errors import DeviceError
    out = {"listed": [[d.path, d.kind] for d in discover()], "opened": {}}
    out["size_from"] = [evdev_size(node) for node in sys.argv[1:]]
    for node in sys.argv[1:]:
        try:
            src = open_device(node)
            out["opened"][node] = [round(v, 6) for v in src.surface_size]
            src.close()
        except DeviceError as exc:
            out["opened"][node] = str(exc)
    print(json.dumps(out))
    """
)


@pytest.mark.umockdev
@pytest.mark.skipif(not umockdev_available(), reason="umockdev-run not installed")
def test_live_pad_and_broken_nodes_are_not_listed_and_say_why_when_opened(tmp_path: Path) -> None:
    """A Wacom tablet's pen and pad nodes (udev tags as udev gives them) and a
    touch screen with an inverted X axis, read through python-evdev's ioctls."""
    pen = device("Wacom Intuos S Pen", PEN_KEYS, pen_axes())
    broken = device(
        "Acme TS", frozenset({e.BTN_TOUCH}), {**mt_axes(10), e.ABS_MT_POSITION_X: ax(4000, 0, 10)},
        e.INPUT_PROP_DIRECT,
    )  # fmt: skip
    tablet = {"ID_INPUT": "1", "ID_INPUT_TABLET": "1"}
    files = [
        write(Recording(pen, [], tmp_path / "a", tmp_path / "a"), tmp_path, num=5, udev=tablet),
        write(
            Recording(WACOM_PAD, [], tmp_path / "b", tmp_path / "b"),
            tmp_path,
            num=6,
            udev={**tablet, "ID_INPUT_TABLET_PAD": "1"},
        ),
        write(
            Recording(broken, [], tmp_path / "c", tmp_path / "c"),
            tmp_path,
            num=7,
            udev={"ID_INPUT": "1", "ID_INPUT_TOUCHSCREEN": "1"},
        ),
    ]
    nodes = [f.node for f in files]
    proc = run_under_umockdev(files, [stiction_cmd()[0], "-c", LIVE_SCRIPT, *nodes])
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    # the pad is no pen; the broken touch screen is still listed (its kind is
    # plain) and says what is wrong when opened
    assert out["listed"] == [[nodes[0], "pen"], [nodes[2], "touchscreen"]]
    assert out["opened"][nodes[0]] == [0.25, 0.15]
    # what backend choice sees (drivers/discovery.py): the broken touch screen's
    # resolution made it "sized" by the kernel, so its evdev node was chosen
    # over a hidraw twin that could be read
    assert out["size_from"] == ["kernel", "", ""]
    assert "'Wacom Intuos S Pad' (056a:0374) is a tablet's button pad" in out["opened"][nodes[1]]
    assert "empty X range (ABS_MT_POSITION_X 4000..0)" in out["opened"][nodes[2]]


REPLUG_READER = textwrap.dedent(
    """
    import json, sys
    from stiction.drivers.evdev import discover, open_device
    from stiction.errors import DeviceError
    src = open_device(sys.argv[1])
    print("ready", flush=True)
    try:
        for s in src.samples():
            print(json.dumps([s.x, s.y, s.in_range]), flush=True)
    except DeviceError as exc:
        print(json.dumps({"error": str(exc)}), flush=True)
    try:
        open_device(sys.argv[1])
    except DeviceError as exc:
        print(json.dumps({"reopen_failed": str(exc)}), flush=True)
    assert sys.stdin.readline() == "replugged\\n"
    listed = [d.path for d in discover()]
    try:
        again = open_device("/dev/input/event6")
        print(json.dumps({"opened": again.name, "listed": listed}), flush=True)
    except DeviceError as exc:
        print(json.dumps({"refused": str(exc), "listed": listed}), flush=True)
    """
)


@pytest.mark.umockdev
@pytest.mark.skipif(not gi_available(), reason="needs system python3 with gi + UMockdev typelib")
def test_a_node_replugged_as_another_device_is_judged_afresh(
    evdev_data: Path, tmp_path: Path
) -> None:
    """The pen is unplugged mid-stroke; what comes back is the tablet's pad. It is
    described from its own capabilities: not listed, and refused with the pad's
    reason, not read with the pen's size it replaced."""
    rec = load(evdev_data / "wacom-cintiq-13hd-touch-pen.evemu")
    syn = [i for i, ev in enumerate(rec.events) if ev[2:4] == (0, 0)]
    rec.events = rec.events[: syn[19] + 1]
    write(rec, tmp_path, num=5, udev={"ID_INPUT": "1", "ID_INPUT_TABLET": "1"})
    pad = Recording(WACOM_PAD, [(1, 0, 0, 0, 0)], tmp_path / "p", tmp_path / "p")
    write(pad, tmp_path, num=6, udev={"ID_INPUT_TABLET": "1", "ID_INPUT_TABLET_PAD": "1"})
    out = run_controller(tmp_path, REPLUG_READER, "20")
    lines = out["reader"]
    samples = [json.loads(x) for x in lines if x.startswith("[")]
    assert len(samples) == 21 and samples[-1][2] is False, out  # the stroke ended
    assert any("went away" in x for x in lines if x.startswith('{"error"')), out
    (last,) = [
        json.loads(x) for x in lines if x.startswith('{"refused"') or x.startswith('{"opened"')
    ]
    assert "'Wacom Intuos S Pad' (056a:0374) is a tablet's button pad" in last["refused"], out
    assert "/dev/input/event6" not in last["listed"]
