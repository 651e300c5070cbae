"""The fast feed loops against FrameAssembler.feed_many_general: same frames, same counters.

feed_many sends a device without slots through `_feed_single`, a loop
generated for the device (single_code.py), and a multi-touch device through
`_feed_mt`; both handle axes, EV_MSC and SYN_REPORT themselves and hand
everything else to feed_many_general one event at a time. Here both paths eat the same events --
every recording, the recordings with SYN_DROPPED put into frames, split into
read()-sized batches at arbitrary points, with and without a live device's
state query, and random streams from hypothesis -- and must give equal frames,
equal counters (all of them) and an equal final `finish()`. The last test
breaks the generated loop on purpose and checks that the comparison notices.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path

import pytest
from evdev import ecodes as e
from hypothesis import given, settings
from hypothesis import strategies as st

from stiction.bench.evdev import RECORDINGS  # the recordings the benchmark times
from stiction.drivers.evdev import single_code
from stiction.drivers.evdev.description import AbsAxis, DeviceDescription
from stiction.drivers.evdev.frames import DeviceState, FrameAssembler
from stiction.drivers.evdev.recording import load

Event = tuple[int, int, int, int, int]


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
#: no BTN_TOOL_*, no BTN_TOUCH: in range once a position arrives, tip from pressure
BARE_PEN = DeviceDescription(
    name="Bare Pen",
    keys=frozenset({e.BTN_STYLUS}),
    axes={
        e.ABS_X: AbsAxis(0, 0, 4000, resolution=40),
        e.ABS_Y: AbsAxis(0, 0, 3000, resolution=40),
        e.ABS_PRESSURE: AbsAxis(0, 5, 1023),
    },
)
#: no pressure, no Y: the defaults the single-tool frame fills in
ODD_PEN = DeviceDescription(
    name="Odd Pen",
    keys=frozenset({e.BTN_TOOL_PEN, e.BTN_STYLUS2}),
    axes={e.ABS_X: AbsAxis(0, 0, 4000, resolution=40)},
)
TOUCHPAD = DeviceDescription(
    name="Test Touchpad",
    properties=frozenset({e.INPUT_PROP_POINTER}),
    keys=frozenset({e.BTN_LEFT, e.BTN_RIGHT, e.BTN_TOOL_FINGER, e.BTN_TOUCH}),
    axes={
        e.ABS_X: AbsAxis(0, 0, 1000, resolution=10),
        e.ABS_Y: AbsAxis(0, 0, 500, resolution=10),
        e.ABS_MT_SLOT: AbsAxis(0, 0, 2),
        e.ABS_MT_POSITION_X: AbsAxis(0, 0, 1000, resolution=10),
        e.ABS_MT_POSITION_Y: AbsAxis(0, 0, 500, resolution=10),
        e.ABS_MT_TRACKING_ID: AbsAxis(0, 0, 65535),
        e.ABS_MT_PRESSURE: AbsAxis(0, 0, 255),
        e.ABS_MT_TOOL_TYPE: AbsAxis(0, 0, 2),
        e.ABS_MT_DISTANCE: AbsAxis(0, 0, 5),
    },
)
DESCS = {"pen": PEN, "bare-pen": BARE_PEN, "odd-pen": ODD_PEN, "touchpad": TOUCHPAD}

STATE = DeviceState(
    keys=frozenset({e.BTN_TOOL_PEN, e.BTN_TOUCH}),
    axes={e.ABS_X: 700, e.ABS_Y: 900, e.ABS_PRESSURE: 300, e.ABS_MT_SLOT: 1},
    slots={e.ABS_MT_TRACKING_ID: [5, 6, -1], e.ABS_MT_POSITION_X: [10, 20, 30]},
)


def _run(
    asm: FrameAssembler, feed: Callable[[list[Event]], list[object]], batches: list[list[Event]]
) -> tuple[list[tuple[object, ...]], dict[str, int], object]:
    frames: list[tuple[object, ...]] = []
    for b in batches:
        frames.extend(tuple(f) for f in feed(b))  # type: ignore[arg-type]
        frames.append(("after batch", asm.needs_resync, asm._dropping))
    stats = dict(asm.stats)
    end = asm.finish(99, 0)
    return frames, stats, tuple(end) if end is not None else None


def same_both_ways(
    desc: DeviceDescription,
    events: list[Event],
    cuts: list[int],
    live: bool = False,
    short_batch: int = 0,
) -> int:
    """Feeds the events in batches cut at `cuts` to both paths; the number of frames.

    short_batch=0: every batch through the fast loops, however short; else
    feed_many's own choice, short batches through the general loop."""
    bounds = [0, *sorted(c for c in cuts if 0 < c < len(events)), len(events)]
    batches = [events[a:b] for a, b in itertools.pairwise(bounds)]
    fast, general = FrameAssembler(desc), FrameAssembler(desc)
    fast.short_batch = short_batch
    if live:
        fast.query_state = general.query_state = lambda: STATE
    got = _run(fast, fast.feed_many, batches)  # type: ignore[arg-type]
    want = _run(general, general.feed_many_general, batches)  # type: ignore[arg-type]
    assert got[0] == want[0]
    assert got[1] == want[1]
    assert got[2] == want[2]
    return len(got[0])


def _with_drops(events: list[Event]) -> list[Event]:
    """A SYN_DROPPED into the middle of every 5th frame (after its first axis event)."""
    out: list[Event] = []
    frame_no = 0
    dropped = False
    for ev in events:
        out.append(ev)
        if ev[2] == e.EV_SYN and ev[3] == e.SYN_REPORT:
            frame_no += 1
            dropped = False
        elif frame_no % 5 == 2 and ev[2] == e.EV_ABS and not dropped:
            out.append((ev[0], ev[1], e.EV_SYN, e.SYN_DROPPED, 0))
            dropped = True
    return out


@pytest.mark.parametrize("name", RECORDINGS)
@pytest.mark.parametrize("live", [False, True], ids=["replay", "live"])
def test_fast_path_equals_general_path_on_recordings(
    evdev_data: Path, name: str, live: bool
) -> None:
    rec = load(evdev_data / name)
    events = list(rec.events)
    assert same_both_ways(rec.description, events, [], live) > 0
    assert same_both_ways(rec.description, events, list(range(3, len(events), 7)), live) > 0
    assert same_both_ways(rec.description, _with_drops(events), list(range(5, 4000, 11)), live)
    # batches of every length, so that feed_many switches between the loops
    cuts = [sum(range(k)) for k in range(1, 100)]
    assert same_both_ways(rec.description, _with_drops(events), cuts, live, short_batch=16)


_codes = st.sampled_from(
    [
        (e.EV_ABS, e.ABS_X),
        (e.EV_ABS, e.ABS_Y),
        (e.EV_ABS, e.ABS_PRESSURE),
        (e.EV_ABS, e.ABS_TILT_X),
        (e.EV_ABS, e.ABS_TILT_Y),
        (e.EV_ABS, e.ABS_DISTANCE),
        (e.EV_ABS, e.ABS_MT_SLOT),
        (e.EV_ABS, e.ABS_MT_SLOT),
        (e.EV_ABS, e.ABS_MT_TRACKING_ID),
        (e.EV_ABS, e.ABS_MT_TRACKING_ID),
        (e.EV_ABS, e.ABS_MT_POSITION_X),
        (e.EV_ABS, e.ABS_MT_POSITION_Y),
        (e.EV_ABS, e.ABS_MT_PRESSURE),
        (e.EV_ABS, e.ABS_MT_TOOL_TYPE),
        (e.EV_ABS, e.ABS_MT_DISTANCE),
        (e.EV_ABS, e.ABS_MT_TOUCH_MAJOR),
        (e.EV_KEY, e.BTN_TOUCH),
        (e.EV_KEY, e.BTN_TOOL_FINGER),
        (e.EV_KEY, e.BTN_LEFT),
        (e.EV_KEY, e.BTN_TOOL_PEN),
        (e.EV_KEY, e.BTN_TOOL_RUBBER),
        (e.EV_KEY, e.BTN_STYLUS),
        (e.EV_KEY, e.BTN_STYLUS2),
        (e.EV_SYN, e.SYN_REPORT),
        (e.EV_SYN, e.SYN_REPORT),
        (e.EV_SYN, e.SYN_REPORT),
        (e.EV_SYN, e.SYN_DROPPED),
        (e.EV_SYN, e.SYN_MT_REPORT),
        (e.EV_MSC, e.MSC_SERIAL),
        (31, 0x2FF),
    ]
)
_values = st.one_of(st.integers(-3, 5), st.integers(-200, 25000), st.integers(-(2**31), 2**31 - 1))


@pytest.mark.parametrize("desc", list(DESCS.values()), ids=list(DESCS))
@settings(max_examples=150, deadline=None)
@given(
    events=st.lists(st.tuples(_codes, _values), max_size=200),
    cuts=st.lists(st.integers(0, 200), max_size=6),
    live=st.booleans(),
)
def test_fast_path_equals_general_path_on_random_streams(
    desc: DeviceDescription,
    events: list[tuple[tuple[int, int], int]],
    cuts: list[int],
    live: bool,
) -> None:
    stream = [(0, i, t, c, v) for i, ((t, c), v) in enumerate(events)]
    same_both_ways(desc, stream, cuts, live)


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("a1 = value\n", "pass\n"),  # Y never changes
        ("abs_[1] = a1\n", "abs_[1] = c1\n"),  # a pending Y lost at a key event
    ],
    ids=["axis-dropped", "handover-loses-pending"],
)
def test_the_comparison_catches_a_broken_fast_path(
    evdev_data: Path, monkeypatch: pytest.MonkeyPatch, old: str, new: str
) -> None:
    """The generated loop, broken on purpose, must disagree with the general path."""
    rec = load(evdev_data / "wacom-intuos4-6x9.desc")
    events = _with_drops(list(rec.events))
    same_both_ways(rec.description, events, [])
    real = single_code.source

    def broken(asm: FrameAssembler) -> str:
        text = real(asm)
        assert old in text
        return text.replace(old, new)

    monkeypatch.setattr(single_code, "source", broken)
    monkeypatch.setattr(single_code, "_FACTORIES", {})
    with pytest.raises(AssertionError):
        same_both_ways(rec.description, events, [])
