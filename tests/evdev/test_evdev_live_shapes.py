"""The shape path's bounds (live_shapes.py): a device sending many shapes grows nothing.

A hostile or broken device can make every read a new shape. The reader must
then stay equal to the assembler (the comparison of test_evdev_live.py), compile
at most MAX_COMPILED shapes per kind of device, remember at most MAX_KNOWN keys,
and leave unknown shapes to its general loop.
"""

from __future__ import annotations

import itertools
import random

import pytest
from evdev import ecodes as e
from hypothesis import given, settings
from hypothesis import strategies as st
from test_evdev_fast_paths import DESCS
from test_evdev_live import SHAPED, Event, same_both_ways

from stiction.drivers.evdev import live_code, live_shapes
from stiction.drivers.evdev.frames import INPUT_EVENT


def _many_shapes(n: int, seed: int) -> tuple[list[Event], list[int]]:
    """`n` reads of whole pen frames, each of a different shape (axes in new orders)."""
    rng = random.Random(seed)
    axes = [e.ABS_X, e.ABS_Y, e.ABS_PRESSURE, e.ABS_TILT_X, e.ABS_TILT_Y]
    seen: set[tuple[int, ...]] = set()
    events: list[Event] = [(0, 0, e.EV_KEY, e.BTN_TOOL_PEN, 1), (0, 0, e.EV_SYN, e.SYN_REPORT, 0)]
    cuts = [2]
    while len(seen) < n:
        shape = tuple(rng.choice(axes) for _ in range(rng.randrange(1, 9)))
        if shape in seen:
            continue
        seen.add(shape)
        events += [(1, len(seen), e.EV_ABS, c, rng.randrange(0, 100)) for c in shape]
        events.append((1, len(seen), e.EV_SYN, e.SYN_REPORT, 0))
        cuts.append(len(events))
    return events, cuts


def test_many_shapes_stay_bounded_and_equal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(live_code, "BOOKS", {})
    monkeypatch.setattr(live_code, "_FACTORIES", {})
    monkeypatch.setattr(live_code, "_BY_IDENTITY", {})
    monkeypatch.setattr(live_shapes, "MAX_COMPILED", 20)
    monkeypatch.setattr(live_shapes, "MAX_KNOWN", 30)
    events, cuts = _many_shapes(60, 1)
    assert same_both_ways(DESCS["pen"], events, cuts) >= 60
    (book,) = live_code.BOOKS.values()
    assert len(book.compiled_items) == 20  # then no more compiled ...
    assert len(book.sources) == 20 and len(book.codes) <= 30  # ... nor remembered
    shaped, reads = SHAPED
    assert 0 < shaped < reads  # the first shapes compiled; past the cap the loop took them
    # a second reader of the kind takes the compiled shapes at once, and no more
    again, again_cuts = _many_shapes(60, 1)
    same_both_ways(DESCS["pen"], again, again_cuts)
    assert len(book.compiled_items) == 20
    assert SHAPED[0] >= 20


def test_a_reader_remembers_a_bounded_number_of_keys(monkeypatch: pytest.MonkeyPatch) -> None:
    """Keys of shapes that are never compiled (keys in them) are remembered up to a bound,
    and a reader that remembers no more stops asking to learn new ones."""
    monkeypatch.setattr(live_code, "BOOKS", {})
    monkeypatch.setattr(live_code, "_FACTORIES", {})
    monkeypatch.setattr(live_code, "_BY_IDENTITY", {})
    monkeypatch.setattr(live_shapes, "MAX_KNOWN", 10)
    known: list[live_shapes.Shapes] = []
    real = live_shapes.Shapes.__init__

    def spy(self: live_shapes.Shapes, *args: object) -> None:
        real(self, *args)  # type: ignore[arg-type]
        known.append(self)

    monkeypatch.setattr(live_shapes.Shapes, "__init__", spy)
    asked: list[object] = []
    real_learn = live_shapes.Shapes.learn

    def learn(self: live_shapes.Shapes, key: tuple[int, ...]) -> object:
        asked.append(key)
        return real_learn(self, key)

    monkeypatch.setattr(live_shapes.Shapes, "learn", learn)
    events: list[Event] = []
    cuts = []
    for i, n in enumerate(itertools.islice(itertools.count(1), 40)):
        # a key and n axes: never a compiled shape, every read a new key
        events += [(0, i, e.EV_KEY, e.BTN_TOOL_PEN, 1)]
        events += [(0, i, e.EV_ABS, e.ABS_X, 5)] * n
        events.append((0, i, e.EV_SYN, e.SYN_REPORT, 0))
        cuts.append(len(events))
    same_both_ways(DESCS["pen"], events, cuts)
    assert known and all(len(s.known) <= 10 for s in known)
    # once full, a reader stops asking: 10 keys learnt, one refused, then none asked
    assert len(asked) == 11 * len(known)
    assert all(len(b.codes) <= 10 and not b.compiled_items for b in live_code.BOOKS.values())
    assert SHAPED[0] == 0


def test_a_shape_key_tells_every_byte_of_type_and_code() -> None:
    """A type or code differing only in its high byte is another shape: an event of
    type 0x103 is no EV_ABS (the assembler ignores the unknown type), code 0x100 of
    EV_ABS no ABS_X (an unknown axis), whatever the low bytes say."""
    x, y = e.ABS_X, e.ABS_Y
    events: list[Event] = [(0, 0, e.EV_KEY, e.BTN_TOOL_PEN, 1), (0, 0, e.EV_SYN, e.SYN_REPORT, 0)]
    cuts = [2]
    for i in range(30):  # the same frame again and again: its shape is compiled
        events += [(1, i, e.EV_ABS, x, 10 + i), (1, i, e.EV_ABS, y, 20 + i)]
        if i % 3 == 1:
            events.append((1, i, 0x100 | e.EV_ABS, x, 99))  # not EV_ABS
        elif i % 3 == 2:
            events.append((1, i, e.EV_ABS, 0x100 | x, 99))  # not ABS_X
        events.append((1, i, e.EV_SYN, e.SYN_REPORT, 0))
        cuts.append(len(events))
    assert same_both_ways(DESCS["pen"], events, cuts) >= 30
    assert SHAPED[0] >= 20  # two of the three shapes are the shape path's


@settings(max_examples=60, deadline=None)
@given(data=st.binary(min_size=24, max_size=24 * 60), cuts=st.lists(st.integers(0, 60)))
def test_random_bytes_read_as_the_assembler_reads_them(data: bytes, cuts: list[int]) -> None:
    """Whole events of random bytes (types and codes with high bytes, values anywhere),
    with SYN_REPORTs put in so that frames end: the same samples and counters."""
    whole = data[: len(data) - len(data) % INPUT_EVENT.size]
    events: list[Event] = []
    for i, ev in enumerate(INPUT_EVENT.iter_unpack(whole)):
        events.append(ev)
        if i % 4 == 3:
            events.append((ev[0], ev[1], e.EV_SYN, e.SYN_REPORT, 0))
    if events:
        same_both_ways(DESCS["pen"], events, cuts)
        same_both_ways(DESCS["touchpad"], events, cuts)
