"""The live reader (live_code.py) against the assembler and frame_samples: same samples.

DeviceSource.samples() runs the reader live_code.py writes for the device
over the node's read()s. Here it eats the same reads as the reference -- the
frame assembler's `feed_many` on the unpacked events and `frame_samples` on
each frame -- and both must give equal samples read by read, equal counters
after every read, and, when the device goes away (DeviceGone raised by the
reads), the same samples ending the contacts and the same final counters.
The reads: every recording the benchmark times cut into one read per frame
(what a device at its report rate delivers), into reads of random sizes (a
read may end mid-frame), the same with SYN_DROPPED put into frames, with and
without a live device's state query; and random streams from hypothesis
with keys, SYN_DROPPED, other SYN codes, unknown types and codes and values
out of range. The last tests break the generated reader on purpose and check
that the comparison notices.
"""

from __future__ import annotations

import dataclasses
import itertools
import random
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from evdev import ecodes as e
from hypothesis import given, settings
from hypothesis import strategies as st
from test_evdev_fast_paths import DESCS, STATE, _codes, _values, _with_drops

from stiction.bench.evdev import RECORDINGS  # the recordings the benchmark times
from stiction.drivers.evdev import live_code, live_mt_code, live_shape_code, sizes
from stiction.drivers.evdev.description import DeviceDescription
from stiction.drivers.evdev.device import DeviceGone, live_reader_for, new_assembler
from stiction.drivers.evdev.frames import INPUT_EVENT, FrameAssembler
from stiction.drivers.evdev.recording import load
from stiction.drivers.evdev.source import frame_samples
from stiction.drivers.evdev.units import SurfaceUnits

Event = tuple[int, int, int, int, int]


#: the last live run's reads taken by a shape function (live_shapes.py), and its reads
SHAPED = [0, 0]


def _reads(events: list[Event], cuts: list[int]) -> list[bytes]:
    """The events packed as read() returns them, one read between cuts (event indices)."""
    bounds = [0, *sorted({c for c in cuts if 0 < c < len(events)}), len(events)]
    return [
        b"".join(INPUT_EVENT.pack(*ev) for ev in events[a:b]) for a, b in itertools.pairwise(bounds)
    ]


def _reference(desc: DeviceDescription, reads: list[bytes], live: bool) -> list[object]:
    """The assembler and frame_samples, read by read; a record of everything seen."""
    asm = FrameAssembler(desc)
    if live:
        asm.query_state = lambda: STATE
    units = SurfaceUnits(desc)
    out: list[object] = []
    for data in reads:
        for frame in asm.feed_many(list(INPUT_EVENT.iter_unpack(data))):
            out += frame_samples(units, frame)
        out.append(("read done", dict(asm.stats)))
    last = INPUT_EVENT.unpack_from(reads[-1], len(reads[-1]) - INPUT_EVENT.size)
    end = asm.finish(last[0], last[1])
    if end is not None:
        out += frame_samples(units, end)
    out.append(("gone", dict(asm.stats)))
    return out


def _live(desc: DeviceDescription, reads: list[bytes], live: bool) -> list[object]:
    """The live reader over the same reads, the device going away after the last,
    on an assembler copied as a device's is when it is opened (new_assembler)."""
    new_assembler(desc)  # the first is made by __init__, the next ones are copies
    asm = new_assembler(desc)
    if live:
        asm.query_state = lambda: STATE
    reader = live_reader_for(asm, SurfaceUnits(desc))
    out: list[object] = []

    def device() -> Iterator[bytes]:
        for data in reads:
            yield data
            # the reader asks for the next read once the last one's samples are taken
            out.append(("read done", dict(asm.stats)))
        raise DeviceGone("unplugged")

    with pytest.raises(DeviceGone):
        for s in reader.samples(device()):
            out.append(s)
    out.append(("gone", dict(asm.stats)))
    SHAPED[:] = [reader.shaped(), len(reads)]
    assert reader.count() == sum(1 for x in out if not isinstance(x, tuple))
    return out


def same_both_ways(
    desc: DeviceDescription, events: list[Event], cuts: list[int], live: bool = False
) -> int:
    """The samples of both paths, compared; how many there were."""
    reads = _reads(events, cuts)
    got, want = _live(desc, reads, live), _reference(desc, reads, live)
    assert got == want
    return sum(1 for x in got if not isinstance(x, tuple))


def _frame_cuts(events: list[Event]) -> list[int]:
    """One read per frame: a cut after every SYN_REPORT."""
    return [i + 1 for i, ev in enumerate(events) if ev[2] == e.EV_SYN and ev[3] == e.SYN_REPORT]


def _desc(evdev_data: Path, name: str) -> tuple[DeviceDescription, list[Event]]:
    rec = load(evdev_data / name)
    size_mm = (100.0, 60.0) if "synaptics" in name else None  # as the benchmark does
    return sizes.apply(rec.description, size_mm), list(rec.events)


@pytest.mark.parametrize("name", RECORDINGS)
@pytest.mark.parametrize("live", [False, True], ids=["replay", "live"])
def test_live_reader_equals_the_assembler_on_recordings(
    evdev_data: Path, name: str, live: bool
) -> None:
    desc, events = _desc(evdev_data, name)
    assert same_both_ways(desc, events, _frame_cuts(events), live) > 0
    # the comparison is about the shape path too: it took most of these reads
    shaped, reads = SHAPED
    assert shaped > reads // 2, (shaped, reads)
    rng = random.Random(name)
    cuts = [rng.randrange(len(events)) for _ in range(len(events) // 4)]
    assert same_both_ways(desc, events, cuts, live) > 0
    dropped = _with_drops(events)
    assert same_both_ways(desc, dropped, _frame_cuts(dropped), live) > 0
    cuts = [rng.randrange(len(dropped)) for _ in range(len(dropped) // 3)]
    assert same_both_ways(desc, dropped, cuts, live) > 0
    # a reader that fell behind: long reads, for the compiled loop or the assembler
    assert same_both_ways(desc, events, list(range(0, len(events), 150)), live) > 0


def test_every_recording_takes_a_generated_reader(evdev_data: Path) -> None:
    """The comparison above is about the generated code: pens and touchpads get one."""
    for name in RECORDINGS:
        desc, _ = _desc(evdev_data, name)
        reader = live_reader_for(FrameAssembler(desc), SurfaceUnits(desc))
        assert reader.source is not None, name
        assert ("slots = asm._slots" in reader.source) == desc.is_multitouch, name


@pytest.mark.parametrize("desc", list(DESCS.values()), ids=list(DESCS))
@settings(max_examples=150, deadline=None)
@given(
    events=st.lists(st.tuples(_codes, _values), min_size=1, max_size=200),
    cuts=st.lists(st.integers(0, 200), max_size=30),
    live=st.booleans(),
)
def test_live_reader_equals_the_assembler_on_random_streams(
    desc: DeviceDescription,
    events: list[tuple[tuple[int, int], int]],
    cuts: list[int],
    live: bool,
) -> None:
    stream = [(i // 7, i, t, c, v) for i, ((t, c), v) in enumerate(events)]
    same_both_ways(desc, stream, cuts, live)


@settings(max_examples=100, deadline=None)
@given(
    frames=st.lists(
        st.lists(
            st.tuples(st.sampled_from([e.ABS_X, e.ABS_Y, e.ABS_PRESSURE]), _values),
            max_size=4,
        ),
        min_size=1,
        max_size=40,
    ),
    extra=st.lists(st.tuples(_codes, _values), max_size=3),
)
def test_live_reader_on_well_formed_frames_with_a_few_odd_events(
    frames: list[list[tuple[int, int]]], extra: list[tuple[tuple[int, int], int]]
) -> None:
    """Mostly the common case (whole frames of axes, one read each), with a few odd
    events at random places: the reader and the assembler take turns."""
    rng = random.Random(len(frames))
    stream: list[Event] = [(0, 1, e.EV_KEY, e.BTN_TOOL_PEN, 1), (0, 1, e.EV_SYN, e.SYN_REPORT, 0)]
    for i, frame in enumerate(frames):
        stream += [(i, 2, e.EV_ABS, code, v) for code, v in frame]
        stream += [(i, 3, e.EV_MSC, e.MSC_SERIAL, 7), (i, 4, e.EV_SYN, e.SYN_REPORT, 0)]
    for (t, c), v in extra:
        stream.insert(rng.randrange(len(stream) + 1), (9, 9, t, c, v))
    assert same_both_ways(DESCS["pen"], stream, _frame_cuts(stream)) > 0


def _two_fingers() -> tuple[list[Event], list[int]]:
    """Two fingers on the test touchpad, then reads that switch slots before a key
    or a SYN_DROPPED sends them to the assembler; one read per line below."""

    def ev(t: int, c: int, v: int) -> Event:
        return (1, 0, t, c, v)

    def mt(code: int) -> Callable[[int], Event]:
        return lambda v: ev(e.EV_ABS, code, v)

    slot, tid = mt(e.ABS_MT_SLOT), mt(e.ABS_MT_TRACKING_ID)
    x, y, p = mt(e.ABS_MT_POSITION_X), mt(e.ABS_MT_POSITION_Y), mt(e.ABS_MT_PRESSURE)
    syn, drop = ev(e.EV_SYN, e.SYN_REPORT, 0), ev(e.EV_SYN, e.SYN_DROPPED, 0)
    touch, touch_up = ev(e.EV_KEY, e.BTN_TOUCH, 1), ev(e.EV_KEY, e.BTN_TOUCH, 0)
    left, left_up = ev(e.EV_KEY, e.BTN_LEFT, 1), ev(e.EV_KEY, e.BTN_LEFT, 0)
    reads = [
        [slot(0), tid(5), x(10), slot(1), tid(6), touch, syn],
        [x(20), syn],  # slot 1 moves
        [x(1020), syn],  # off the surface (X is 0..1000): its sample is clamped
        [x(30), syn],
        [slot(0), y(30), syn],
        # a frame of slot 0, then slot 1 in a dropped frame: the assembler takes the
        # read from its start, slot 0 current again
        [x(40), syn, slot(1), y(50), drop, syn],
        [x(60), syn],
        [left, x(61), syn],  # a button: every contact carries it
        [left_up, x(62), drop, syn],  # released in a dropped frame: still down after
        [x(63), syn],
        [slot(1), tid(-1), syn],  # finger 6 lifts
        [slot(0), x(64), y(31), p(300), syn],
        [tid(-1), touch_up, syn],  # finger 5 lifts
    ]
    cuts = list(itertools.accumulate(len(r) for r in reads))
    return [x for r in reads for x in r], cuts


def test_two_fingers_across_slot_switches_and_hand_overs() -> None:
    events, cuts = _two_fingers()
    assert same_both_ways(DESCS["touchpad"], events, cuts) >= 10


def _pen_story() -> tuple[list[Event], list[int]]:
    """The test pen comes into proximity, presses its button, swaps to the eraser
    and leaves, with dropped frames around key changes; one read per line."""

    def ev(t: int, c: int, v: int) -> Event:
        return (2, 0, t, c, v)

    def key(code: int) -> Callable[[int], Event]:
        return lambda v: ev(e.EV_KEY, code, v)

    def axis(code: int) -> Callable[[int], Event]:
        return lambda v: ev(e.EV_ABS, code, v)

    pen, rubber, stylus, touch = (
        key(c) for c in (e.BTN_TOOL_PEN, e.BTN_TOOL_RUBBER, e.BTN_STYLUS, e.BTN_TOUCH)
    )
    x, y, p = axis(e.ABS_X), axis(e.ABS_Y), axis(e.ABS_PRESSURE)
    syn, drop = ev(e.EV_SYN, e.SYN_REPORT, 0), ev(e.EV_SYN, e.SYN_DROPPED, 0)
    reads = [
        [pen(1), x(500), y(600), syn],
        [x(510), syn],
        [touch(1), p(300), syn],
        [stylus(1), x(520), syn],  # the button: buttons follow
        [stylus(0), x(530), drop, syn],  # released in a dropped frame: still down after
        [x(540), syn],
        [pen(0), rubber(1), syn],  # the eraser, no contact ended
        [x(30000), syn],  # off the surface: clamped
        [touch(0), p(0), syn],
        [rubber(0), syn],  # out of proximity: the last sample, ended
        [x(600), syn],
    ]
    cuts = list(itertools.accumulate(len(r) for r in reads))
    return [x for r in reads for x in r], cuts


def test_pen_keys_drops_and_proximity() -> None:
    events, cuts = _pen_story()
    assert same_both_ways(DESCS["pen"], events, cuts) >= 9


def _no_restore(text: str) -> str:
    """The reader's state is not put back before the assembler takes a read."""
    out, n = re.subn(r"\n( +)[^\n]* = snap\n", r"\n\1pass\n", text)
    assert n == 1
    return out


BREAKS: dict[str, Callable[[str], str]] = {
    # a touchpad's Y never changes
    "mt-axis-dropped": lambda text: text.replace("vals[base + 1] = value\n", "pass\n"),
    # a touchpad's position off the surface is not clamped (the Synaptics's X is)
    "mt-clamp-skipped": lambda text: text.replace("    inside = False\n", "    pass\n"),
    # a touchpad's slot is not put back before the assembler takes a read
    "mt-restore-lost": lambda text: text.replace(
        "vals[:], cur, active, buttons, rebuild, keys_changed, inside = snap",
        "vals[:], cur_lost, active, buttons, rebuild, keys_changed, inside = snap",
    ),
    # a lifted finger's last sample still in range
    "mt-ended-in-range": lambda text: text.replace("s.in_range = False", "s.in_range = True"),
    # a key's change not undone before the assembler takes the read
    "mt-keys-not-restored": lambda text: text.replace("keys.update(ksnap)", "pass"),
    # a button press not seen
    "mt-key-ignored": lambda text: text.replace("keys.add(code)", "pass"),
    # a pen's Y never changes
    "axis-dropped": lambda text: text.replace("c1 = value\n", "pass\n"),
    "restore-lost": _no_restore,
    # the tip does not follow BTN_TOUCH
    "tip-wrong": lambda text: text.replace("s.tip = key_touch\n", "s.tip = True\n"),
    # a pen's last sample, when it leaves proximity, still in range
    "ended-in-range": lambda text: text.replace("s.in_range = False", "s.in_range = True"),
    # a pen's key change not undone before the assembler takes the read
    "keys-not-restored": lambda text: text.replace("keys.update(ksnap)", "pass"),
    # a one-frame read's samples a nanosecond late (the time is given after the loop)
    "time-wrong": lambda text: text.replace("first.t = t\n", "first.t = t + 1e-9\n"),
    # a read ending mid-frame is not handed over
    "partial-frame-dropped": lambda text: text.replace(
        "if ev_type == 0:  # the read ends", "if True:  # the read ends"
    ),
}


def _wider(text: str) -> str:
    """Every upper range literal of a shape function wider: values out of range go uncounted."""
    out, n = re.subn(r"(v\d+) > (-?\d+)", lambda m: f"{m[1]} > {int(m[2]) + 100000}", text)
    return out if n else text


SHAPE_BREAKS: dict[str, Callable[[str], str]] = {
    # a pen's shape function stores X's value into Y
    "shape-value-swapped": lambda text: text.replace("c0 = v", "c1 = v"),
    # a pen's shape function takes a field from its cache without checking the value
    "shape-cache-stale": lambda text: re.sub(r"if c(\d+) == r\1:", r"if r\1 is not None:", text),
    # a touchpad's shape function tests the wrong range (the Synaptics's X goes beyond)
    "mt-shape-range-wrong": _wider,
    # a touchpad's shape function leaves the current slot where the read began
    "mt-shape-slot-kept": lambda text: re.sub(r"cur = v\d+\n", "pass\n", text),
}


@pytest.mark.parametrize("how", [*BREAKS, *SHAPE_BREAKS])
def test_the_comparison_catches_a_broken_live_reader(
    evdev_data: Path, monkeypatch: pytest.MonkeyPatch, how: str
) -> None:
    """The generated reader, broken on purpose, must disagree with the assembler.

    A break of the reader's loop is made in its shape functions too (they are
    written apart); SHAPE_BREAKS break only the shape functions."""
    name = "synaptics-touchpad.hp8470p.desc" if how.startswith("mt-") else "wacom-intuos4-6x9.desc"
    desc, events = _desc(evdev_data, name)
    events = _with_drops(events)
    rng = random.Random(1)
    cuts = [rng.randrange(len(events)) for _ in range(len(events) // 3)]
    same_both_ways(desc, events, cuts)
    module = live_mt_code if desc.is_multitouch else live_code
    writer = "mt_body" if desc.is_multitouch else "pen_body"
    real, real_shape = module.source, getattr(live_shape_code, writer)
    text = real(FrameAssembler(desc), SurfaceUnits(desc))
    change = BREAKS.get(how) or SHAPE_BREAKS[how]
    if how in BREAKS:
        assert change(text) != text  # here, not inside pytest.raises below

        def broken(asm: FrameAssembler, units: SurfaceUnits) -> str:
            return change(real(asm, units))

        monkeypatch.setattr(module, "source", broken)
    changed = []

    def broken_shape(asm: FrameAssembler, units: SurfaceUnits, shape: Any) -> str | None:
        body = real_shape(asm, units, shape)
        if body is not None and change(body) != body:
            changed.append(shape)
            return change(body)
        return body

    monkeypatch.setattr(live_shape_code, writer, broken_shape)
    monkeypatch.setattr(live_code, "BOOKS", {})
    monkeypatch.setattr(live_code, "_FACTORIES", {})
    monkeypatch.setattr(live_code, "_BY_IDENTITY", {})
    with pytest.raises(AssertionError):
        same_both_ways(desc, events, cuts)
        same_both_ways(desc, events, _frame_cuts(events))
        same_both_ways(DESCS["touchpad"], *_two_fingers())
        same_both_ways(DESCS["pen"], *_pen_story())
    if how in SHAPE_BREAKS:
        assert changed  # the shape functions were broken, and that was noticed


def test_the_comparison_catches_a_read_of_several_frames_timed_wrong(
    evdev_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A read of several frames gives each sample its own frame's time (`stamped`):
    every sample at the read's first frame's time must disagree with the assembler."""
    desc, events = _desc(evdev_data, "wacom-intuos5-touch-m-finger.desc")
    cuts = list(range(0, len(events), 20))  # reads of several frames
    same_both_ways(desc, events, cuts)
    real = live_mt_code.stamped

    def first_time_only(data: bytes, first: Any, rest: list[Any] | None) -> list[Any]:
        out = real(data, first, rest)
        return [dataclasses.replace(x, t=out[0].t) for x in out]

    monkeypatch.setattr(live_mt_code, "stamped", first_time_only)
    monkeypatch.setattr(live_code, "_FACTORIES", {})
    monkeypatch.setattr(live_code, "_BY_IDENTITY", {})
    with pytest.raises(AssertionError):
        same_both_ways(desc, events, cuts)
