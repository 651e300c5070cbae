"""The frame assembler on hand-made and random event streams: impossible input never crashes."""

from __future__ import annotations

from pathlib import Path

import pytest
from evdev import ecodes as e
from hypothesis import given
from hypothesis import strategies as st

from stiction.drivers.evdev.description import AbsAxis, DeviceDescription
from stiction.drivers.evdev.frames import DeviceState, Frame, FrameAssembler
from stiction.drivers.evdev.recording import load
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import Tool

EV_SYN, EV_KEY, EV_ABS = e.EV_SYN, e.EV_KEY, e.EV_ABS

TOUCHPAD = DeviceDescription(
    name="Test Touchpad",
    properties=frozenset({e.INPUT_PROP_POINTER}),
    keys=frozenset({e.BTN_LEFT, e.BTN_TOOL_FINGER, e.BTN_TOUCH, e.BTN_TOOL_DOUBLETAP}),
    axes={
        e.ABS_X: AbsAxis(0, 0, 1000, resolution=10),
        e.ABS_Y: AbsAxis(0, 0, 500, resolution=10),
        e.ABS_MT_SLOT: AbsAxis(0, 0, 1),
        e.ABS_MT_POSITION_X: AbsAxis(0, 0, 1000, resolution=10),
        e.ABS_MT_POSITION_Y: AbsAxis(0, 0, 500, resolution=10),
        e.ABS_MT_TRACKING_ID: AbsAxis(0, 0, 65535),
        e.ABS_MT_PRESSURE: AbsAxis(0, 0, 255),
    },
)

PEN = DeviceDescription(
    name="Test Pen",
    keys=frozenset({e.BTN_TOOL_PEN, e.BTN_TOOL_RUBBER, e.BTN_TOUCH, e.BTN_STYLUS, e.BTN_STYLUS2}),
    axes={
        e.ABS_X: AbsAxis(0, 100, 20100, resolution=100),
        e.ABS_Y: AbsAxis(0, 100, 10100, resolution=100),
        e.ABS_PRESSURE: AbsAxis(0, 0, 1023),
        e.ABS_TILT_X: AbsAxis(0, -64, 63, resolution=57),
        e.ABS_TILT_Y: AbsAxis(0, -64, 63, resolution=57),
    },
)


class Stream:
    """Writes events with a running kernel time, one frame per syn()."""

    def __init__(self, asm: FrameAssembler) -> None:
        self.asm = asm
        self.usec = 0
        self.frames: list[Frame] = []

    def ev(self, t: int, c: int, v: int) -> Frame | None:
        f = self.asm.feed(0, self.usec, t, c, v)
        if f is not None:
            self.frames.append(f)
        return f

    def abs(self, c: int, v: int) -> None:
        self.ev(EV_ABS, c, v)

    def key(self, c: int, v: int) -> None:
        self.ev(EV_KEY, c, v)

    def syn(self) -> Frame | None:
        f = self.ev(EV_SYN, e.SYN_REPORT, 0)
        self.usec += 7000
        return f


def touch(s: Stream, slot: int, tid: int, x: int, y: int) -> None:
    s.abs(e.ABS_MT_SLOT, slot)
    s.abs(e.ABS_MT_TRACKING_ID, tid)
    s.abs(e.ABS_MT_POSITION_X, x)
    s.abs(e.ABS_MT_POSITION_Y, y)


def test_two_fingers_begin_move_end() -> None:
    s = Stream(FrameAssembler(TOUCHPAD))
    touch(s, 0, 10, 100, 100)
    f = s.syn()
    assert f is not None and [(c.id, c.slot, c.x, c.y, c.tip) for c in f.contacts] == [
        (10, 0, 100, 100, True)
    ]
    touch(s, 1, 11, 300, 200)
    s.abs(e.ABS_MT_SLOT, 0)
    s.abs(e.ABS_MT_POSITION_X, 110)
    f = s.syn()
    assert f is not None and {(c.id, c.x) for c in f.contacts} == {(10, 110), (11, 300)}
    s.abs(e.ABS_MT_TRACKING_ID, -1)  # slot 0 still selected
    f = s.syn()
    assert f is not None
    assert [c.id for c in f.contacts] == [11]
    assert [(c.id, c.x, c.in_range, c.tip) for c in f.ended] == [(10, 110, False, False)]
    s.abs(e.ABS_MT_SLOT, 1)
    s.abs(e.ABS_MT_TRACKING_ID, -1)
    f = s.syn()
    assert f is not None and f.contacts == () and [c.id for c in f.ended] == [11]


def test_syn_dropped_mid_frame_discards_partial_frame_and_counts() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 0, 1, 100, 100)
    s.syn()
    s.abs(e.ABS_MT_POSITION_X, 900)  # half a frame, then the buffer overflowed
    s.ev(EV_SYN, e.SYN_DROPPED, 0)
    s.abs(e.ABS_MT_POSITION_X, 950)  # still part of the dropped stretch
    assert s.syn() is None  # the SYN_REPORT that ends the dropped stretch
    assert asm.needs_resync and asm.stats["syn_dropped"] == 1
    s.abs(e.ABS_MT_POSITION_Y, 120)
    f = s.syn()
    assert f is not None and [(c.x, c.y) for c in f.contacts] == [(100, 120)]
    assert asm.stats["events_discarded"] == 2


def test_resync_adopts_device_state() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 0, 1, 100, 100)
    touch(s, 1, 2, 500, 200)
    s.syn()
    s.ev(EV_SYN, e.SYN_DROPPED, 0)
    s.syn()
    # meanwhile finger 1 lifted, finger 2 moved and a third finger landed in slot 0
    state = DeviceState(
        keys=frozenset({e.BTN_TOUCH, e.BTN_TOOL_DOUBLETAP}),
        axes={e.ABS_MT_SLOT: 1},
        slots={
            e.ABS_MT_TRACKING_ID: [3, 2],
            e.ABS_MT_POSITION_X: [50, 600],
            e.ABS_MT_POSITION_Y: [60, 250],
        },
    )
    f = asm.resync(state, 1, 0)
    assert {(c.id, c.x, c.y) for c in f.contacts} == {(3, 50, 60), (2, 600, 250)}
    assert [c.id for c in f.ended] == [1]
    assert not asm.needs_resync and asm.stats["resyncs"] == 1


def test_resync_without_slot_ioctl_uses_current_slot_values() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 0, 1, 100, 100)
    s.syn()
    state = DeviceState(
        keys=frozenset(), axes={e.ABS_MT_SLOT: 0, e.ABS_MT_POSITION_X: 400}, slots={}
    )
    f = asm.resync(state, 1, 0)
    assert [(c.id, c.x, c.y) for c in f.contacts] == [(1, 400, 100)]


def test_slot_beyond_maximum_is_skipped_and_counted() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 5, 7, 100, 100)  # the device has 2 slots
    f = s.syn()
    assert f is not None and f.contacts == ()
    assert asm.stats["slot_out_of_range"] == 4
    touch(s, -1, 8, 100, 100)
    touch(s, 1, 9, 100, 100)
    f = s.syn()
    assert f is not None and [c.id for c in f.contacts] == [9]


def test_tracking_id_reused_in_second_slot_is_skipped() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 0, 4, 100, 100)
    touch(s, 1, 4, 300, 300)
    f = s.syn()
    assert f is not None and [(c.id, c.slot) for c in f.contacts] == [(4, 0)]
    assert asm.stats["tracking_id_reused"] == 1


def test_tracking_id_replaced_without_release_ends_old_contact() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 0, 4, 100, 100)
    s.syn()
    touch(s, 0, 5, 200, 200)
    f = s.syn()
    assert f is not None and [c.id for c in f.contacts] == [5] and [c.id for c in f.ended] == [4]
    assert asm.stats["tracking_id_replaced"] == 1


def test_out_of_range_values_are_kept_and_counted() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 0, 1, -50, 700)
    s.abs(e.ABS_MT_PRESSURE, 1000)
    f = s.syn()
    assert f is not None and (f.contacts[0].x, f.contacts[0].y) == (-50, 700)
    assert asm.stats["value_out_of_range"] == 3
    assert SurfaceUnits(TOUCHPAD).pressure(f.contacts[0].pressure) == 1.0


def test_unknown_codes_and_bad_key_values_are_counted() -> None:
    asm = FrameAssembler(PEN)
    s = Stream(asm)
    s.abs(e.ABS_MT_POSITION_X, 5)  # not an axis of this device
    s.key(e.KEY_A, 1)
    s.key(e.BTN_TOOL_PEN, 7)
    f = s.syn()
    assert f is not None and f.contacts == ()
    assert asm.stats["unknown_code"] == 2 and asm.stats["bad_key_value"] == 1


def test_pen_hover_touch_buttons_tool_and_proximity_out() -> None:
    s = Stream(FrameAssembler(PEN))
    s.key(e.BTN_TOOL_PEN, 1)
    s.abs(e.ABS_X, 5100)
    s.abs(e.ABS_Y, 2100)
    s.abs(e.ABS_TILT_X, 57)
    f = s.syn()
    assert f is not None
    (c,) = f.contacts
    assert (c.id, c.tool, c.tip, c.x, c.tilt_x) == (0, Tool.PEN, False, 5100, 57)
    s.key(e.BTN_TOUCH, 1)
    s.abs(e.ABS_PRESSURE, 1023)
    s.key(e.BTN_STYLUS2, 1)
    f = s.syn()
    assert f is not None
    (c,) = f.contacts
    assert c.tip and c.pressure == 1023 and c.buttons == 2
    sample = SurfaceUnits(PEN).sample(c, f.time)
    assert sample.x == pytest.approx(0.05) and sample.y == pytest.approx(0.02)
    assert sample.pressure == 1.0 and sample.tilt_x == pytest.approx(57.29577951308232)  # 1 rad
    s.key(e.BTN_TOUCH, 0)
    s.key(e.BTN_TOOL_PEN, 0)
    s.abs(e.ABS_X, 0)
    s.abs(e.ABS_Y, 0)
    f = s.syn()
    assert f is not None and f.contacts == ()
    (end,) = f.ended
    assert (end.x, end.y, end.in_range, end.tip) == (5100, 2100, False, False)


def test_finish_ends_all_contacts_once() -> None:
    asm = FrameAssembler(TOUCHPAD)
    s = Stream(asm)
    touch(s, 0, 1, 1, 1)
    touch(s, 1, 2, 2, 2)
    s.syn()
    f = asm.finish(9, 0)
    assert f is not None and sorted(c.id for c in f.ended) == [1, 2]
    assert asm.finish(9, 1) is None


# -- random streams -----------------------------------------------------------

_codes = st.sampled_from(
    [
        (EV_ABS, e.ABS_MT_SLOT),
        (EV_ABS, e.ABS_MT_TRACKING_ID),
        (EV_ABS, e.ABS_MT_POSITION_X),
        (EV_ABS, e.ABS_MT_POSITION_Y),
        (EV_ABS, e.ABS_MT_PRESSURE),
        (EV_ABS, e.ABS_X),
        (EV_ABS, e.ABS_PRESSURE),
        (EV_ABS, e.ABS_TILT_X),
        (EV_KEY, e.BTN_TOUCH),
        (EV_KEY, e.BTN_TOOL_PEN),
        (EV_KEY, e.BTN_TOOL_RUBBER),
        (EV_KEY, e.BTN_TOOL_FINGER),
        (EV_KEY, e.BTN_STYLUS),
        (EV_SYN, e.SYN_REPORT),
        (EV_SYN, e.SYN_DROPPED),
        (EV_SYN, e.SYN_MT_REPORT),
        (4, 0),
        (31, 0x2FF),
    ]
)
_values = st.one_of(st.integers(-3, 5), st.integers(-(2**31), 2**31 - 1))
_events = st.lists(st.tuples(_codes, _values), max_size=300)


@pytest.mark.parametrize("desc", [TOUCHPAD, PEN], ids=["touchpad", "pen"])
@given(events=_events)
def test_random_streams_never_crash_and_contacts_stay_consistent(
    desc: DeviceDescription, events: list[tuple[tuple[int, int], int]]
) -> None:
    asm = FrameAssembler(desc)
    units = SurfaceUnits(desc)
    w, h = units.surface_size or (0.0, 0.0)
    active: set[int] = set()
    usec = 0
    for (t, c), v in events:
        usec += 1
        f = asm.feed(0, usec, t, c, v)
        if f is None:
            continue
        ids = [x.id for x in f.contacts]
        assert len(ids) == len(set(ids)), "one contact id per frame"
        assert {x.id for x in f.ended} <= active, "only active contacts can end"
        assert not ({x.id for x in f.ended} & set(ids))
        for x in f.contacts:
            smp = units.sample(x, f.time)
            assert smp.pressure is None or 0.0 <= smp.pressure <= 1.0
            assert 0.0 <= smp.x <= w and 0.0 <= smp.y <= h, "samples stay on the surface"
            assert smp.t == f.time
            if desc is TOUCHPAD:
                assert x.slot is not None and 0 <= x.slot < desc.num_slots
        for x in f.ended:
            assert not x.in_range and not x.tip
        active = set(ids)
    end = asm.finish(0, usec + 1)
    assert {x.id for x in (end.ended if end else ())} == active


def test_recorded_stream_with_syn_dropped_inserted(evdev_data: Path) -> None:
    """A SYN_DROPPED inserted mid-frame into a real recording loses only that stretch."""
    rec = load(evdev_data / "cypress-trackpad.two-finger-press.evemu")
    ev = list(rec.events)
    clean = FrameAssembler(rec.description).feed_all(ev)
    syn_idx = [i for i, x in enumerate(ev) if x[2] == EV_SYN and x[3] == e.SYN_REPORT]
    cut = syn_idx[10] + 2  # two events into frame 11
    s, u = ev[cut][:2]
    ev.insert(cut, (s, u, EV_SYN, e.SYN_DROPPED, 0))
    asm = FrameAssembler(rec.description)
    dropped = asm.feed_all(ev)
    assert len(dropped) == len(clean) - 1
    assert [(f.sec, f.usec) for f in dropped] == [
        (f.sec, f.usec) for i, f in enumerate(clean) if i != 11
    ]
    assert dropped[:11] == clean[:11]
    assert asm.stats["syn_dropped"] == 1


# -- the one-pass assembler against the plain buffer-then-apply oracle --------------


def _same_as_reference(
    desc: DeviceDescription, events: list[tuple[int, int, int, int, int]]
) -> int:
    from evdev_reference_frames import FrameAssembler as Reference

    ours, ref = FrameAssembler(desc), Reference(desc)
    got = ours.feed_many(events)
    want = ref.feed_many(events)
    assert [tuple(f) for f in got] == [tuple(f) for f in want]
    for key in ("frames", "syn_dropped", "events_discarded"):
        assert ours.stats[key] == ref.stats[key], key
    a, b = ours.finish(99, 0), ref.finish(99, 0)
    assert (tuple(a) if a else None) == (tuple(b) if b else None)
    return int(ours.stats["syn_dropped"])


@pytest.mark.parametrize(
    "name",
    [
        "wacom-cintiq-13hd-touch-pen.evemu",
        "wacom-cintiq-12wx.evemu",
        "wacom-intuos4-6x9.desc",
        "uc-logic-wp5540u-pen.evemu",
        "wacom-cintiq-13hd-touch-finger.evemu",
        "cypress-trackpad.two-finger-press.evemu",
        "elantech-touchpad.samsung-700z3a.evemu",
        "synaptics-touchpad.hp8470p.desc",
        "wacom-intuos5-touch-m-finger.desc",
    ],
)
def test_one_pass_assembler_equals_reference_on_recordings(evdev_data: Path, name: str) -> None:
    rec = load(evdev_data / name)
    _same_as_reference(rec.description, rec.events)
    # and with a SYN_DROPPED put into the middle of every 7th frame
    ev = []
    frame_no = 0
    for x in rec.events:
        ev.append(x)
        if x[2] == EV_SYN and x[3] == e.SYN_REPORT:
            frame_no += 1
        elif frame_no % 7 == 3 and x[2] == EV_ABS:
            ev.append((x[0], x[1], EV_SYN, e.SYN_DROPPED, 0))
            frame_no += 1  # one per frame
    assert _same_as_reference(rec.description, ev) > 0


@pytest.mark.parametrize("desc", [TOUCHPAD, PEN], ids=["touchpad", "pen"])
@given(events=_events)
def test_one_pass_assembler_equals_reference_on_random_streams(
    desc: DeviceDescription, events: list[tuple[tuple[int, int], int]]
) -> None:
    _same_as_reference(desc, [(0, i, t, c, v) for i, ((t, c), v) in enumerate(events)])


def test_palm_is_not_a_contact_and_a_finger_turning_palm_ends() -> None:
    desc = DeviceDescription(
        name="Palm Pad",
        keys=TOUCHPAD.keys,
        axes={**TOUCHPAD.axes, e.ABS_MT_TOOL_TYPE: AbsAxis(0, 0, 2)},
    )
    s = Stream(FrameAssembler(desc))
    touch(s, 0, 1, 100, 100)
    touch(s, 1, 2, 300, 300)
    s.abs(e.ABS_MT_TOOL_TYPE, 2)  # slot 1 is a palm from the start
    f = s.syn()
    assert f is not None and [c.id for c in f.contacts] == [1]
    s.abs(e.ABS_MT_SLOT, 0)
    s.abs(e.ABS_MT_TOOL_TYPE, 2)  # the finger in slot 0 becomes a palm
    f = s.syn()
    assert f is not None and f.contacts == () and [c.id for c in f.ended] == [1]
    s.abs(e.ABS_MT_TOOL_TYPE, 0)  # and back to a finger: the same id begins again
    s.abs(e.ABS_MT_POSITION_X, 120)
    f = s.syn()
    assert f is not None and [(c.id, c.x) for c in f.contacts] == [(1, 120)]


def test_hover_on_a_touchscreen_is_distance_above_zero() -> None:
    desc = DeviceDescription(
        name="Hover Screen",
        properties=frozenset({e.INPUT_PROP_DIRECT}),
        keys=frozenset({e.BTN_TOUCH}),
        axes={**TOUCHPAD.axes, e.ABS_MT_DISTANCE: AbsAxis(0, 0, 10)},
    )
    assert desc.kind == "touchscreen"
    s = Stream(FrameAssembler(desc))
    touch(s, 0, 3, 10, 10)
    s.abs(e.ABS_MT_DISTANCE, 4)
    f = s.syn()
    assert f is not None and [(c.id, c.tip) for c in f.contacts] == [(3, False)]
    s.abs(e.ABS_MT_DISTANCE, 0)
    f = s.syn()
    assert f is not None and [(c.id, c.tip) for c in f.contacts] == [(3, True)]


def test_pen_without_touch_key_or_tool_bits_uses_pressure_for_tip() -> None:
    desc = DeviceDescription(
        name="Bare Pen",
        keys=frozenset({e.BTN_STYLUS}),
        axes={
            e.ABS_X: AbsAxis(0, 0, 1000, resolution=10),
            e.ABS_Y: AbsAxis(0, 0, 1000, resolution=10),
            e.ABS_PRESSURE: AbsAxis(0, 0, 1023),
        },
    )
    assert desc.kind == "pen"
    s = Stream(FrameAssembler(desc))
    assert s.syn() is not None and s.frames[-1].contacts == ()  # nothing reported yet
    s.abs(e.ABS_X, 500)
    f = s.syn()
    assert f is not None and [(c.tool, c.tip) for c in f.contacts] == [(Tool.PEN, False)]
    s.abs(e.ABS_PRESSURE, 300)
    s.key(e.BTN_STYLUS, 1)
    f = s.syn()
    assert f is not None and [(c.tip, c.buttons) for c in f.contacts] == [(True, 1)]


def test_touchpad_buttons_reach_every_contact() -> None:
    s = Stream(FrameAssembler(TOUCHPAD))
    touch(s, 0, 1, 10, 10)
    touch(s, 1, 2, 20, 20)
    s.syn()
    s.key(e.BTN_LEFT, 1)
    f = s.syn()
    assert f is not None and [c.buttons for c in f.contacts] == [1, 1]
    s.key(e.BTN_LEFT, 0)
    s.abs(e.ABS_MT_POSITION_X, 30)  # slot 1 is still selected
    f = s.syn()
    assert f is not None and [(c.x, c.buttons) for c in f.contacts] == [(10, 0), (30, 0)]
