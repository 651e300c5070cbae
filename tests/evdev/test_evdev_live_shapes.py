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
from test_evdev_fast_paths import DESCS
from test_evdev_live import SHAPED, Event, same_both_ways

from stiction.drivers.evdev import live_code, live_shapes


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
    assert book.compiled == 20  # then no more compiled ...
    assert len(book.sources) == 20 and len(book.codes) <= 30  # ... nor remembered
    shaped, reads = SHAPED
    assert 0 < shaped < reads  # the first shapes compiled; past the cap the loop took them
    # a second reader of the kind takes the compiled shapes at once, and no more
    again, again_cuts = _many_shapes(60, 1)
    same_both_ways(DESCS["pen"], again, again_cuts)
    assert book.compiled == 20
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
    assert all(len(b.codes) <= 10 and b.compiled == 0 for b in live_code.BOOKS.values())
    assert SHAPED[0] == 0
