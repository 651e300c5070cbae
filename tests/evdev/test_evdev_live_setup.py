"""A live device's set-up: `new_assembler` copies an assembler made once per description.

The copy must be a new FrameAssembler in everything but the cost: equal
attributes, nothing mutable shared with the template or with another copy,
`feed_many` bound to itself; and it must stop copying (rather than share
state) once FrameAssembler holds something it does not know to be immutable.
The differential tests in test_evdev_live.py run the live reader on copies.
"""

from __future__ import annotations

import enum
import functools
from pathlib import Path
from typing import Any

import pytest
from test_evdev_live import _desc, _frame_cuts, _reads

from stiction.bench.evdev import RECORDINGS
from stiction.drivers.evdev import device
from stiction.drivers.evdev.description import DeviceDescription
from stiction.drivers.evdev.device import new_assembler
from stiction.drivers.evdev.frames import FrameAssembler, _Slot

_SHAREABLE = (int, float, str, type(None), frozenset, tuple, enum.Enum)


def _plain(value: Any, owner: FrameAssembler) -> Any:
    """An attribute's value in comparable form (slots by their fields, feed_many by
    what it calls and on which assembler)."""
    if isinstance(value, _Slot):
        return ("slot", value.state())
    if isinstance(value, list):
        return [_plain(v, owner) for v in value]
    if isinstance(value, functools.partial):
        return ("partial", _plain(value.func, owner), value.args, value.keywords)
    if hasattr(value, "__self__") and hasattr(value, "__func__"):
        return ("bound", value.__func__, "itself" if value.__self__ is owner else value.__self__)
    return value


def _mutables(attrs: dict[str, object]) -> list[object]:
    """The mutable objects among an assembler's attributes (its slots included)."""
    out: list[object] = []
    for name, value in attrs.items():
        if name == "desc" or isinstance(value, _SHAREABLE):
            continue
        out.append(value)
        if isinstance(value, list):
            out += value
    return out


def _same_as_new(copy: FrameAssembler, desc: DeviceDescription) -> None:
    fresh = FrameAssembler(desc)
    assert type(copy) is FrameAssembler
    assert vars(copy).keys() == vars(fresh).keys()
    for name, value in vars(fresh).items():
        assert _plain(getattr(copy, name), copy) == _plain(value, fresh), name


@pytest.mark.parametrize("name", RECORDINGS)
def test_a_copy_is_a_new_assembler_sharing_nothing_mutable(evdev_data: Path, name: str) -> None:
    desc, events = _desc(evdev_data, name)
    first = new_assembler(desc)  # made by __init__; the template is kept beside it
    assert device._TEMPLATES[id(desc)][1] is not None, "copying is off for this device"
    a, b = new_assembler(desc), new_assembler(desc)
    for asm in (first, a, b):
        _same_as_new(asm, desc)
    template = device._TEMPLATES[id(desc)][1]
    assert template is not None
    ids = [{id(x) for x in _mutables(attrs)} for attrs in (vars(first), vars(a), vars(b), template)]
    assert all(len(one) >= 9 for one in ids)
    for i, one in enumerate(ids):
        for other in ids[i + 1 :]:
            assert not one & other
    # one copy's use leaves the next copy as new
    frames = a.feed_many(list(events))
    assert frames
    assert a.stats["frames"] == len(frames)
    _same_as_new(new_assembler(desc), desc)
    _same_as_new(b, desc)


def test_copies_read_as_new_assemblers_do(evdev_data: Path) -> None:
    """The same samples from a reader on a copy as on an assembler made by __init__."""
    desc, events = _desc(evdev_data, "synaptics-touchpad.hp8470p.desc")
    reads = _reads(events, _frame_cuts(events))
    units = device.SurfaceUnits(desc)
    new_assembler(desc)
    got = list(device.live_reader_for(new_assembler(desc), units).samples(reads))
    want = list(device.live_reader_for(FrameAssembler(desc), units).samples(reads))
    assert got == want
    assert len(got) > 100


def test_an_assembler_holding_something_unknown_is_not_copied(
    evdev_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = FrameAssembler.__init__

    def init(self: FrameAssembler, desc: DeviceDescription) -> None:
        real(self, desc)
        self._history = []  # type: ignore[attr-defined]  # a new mutable attribute

    monkeypatch.setattr(FrameAssembler, "__init__", init)
    desc, _ = _desc(evdev_data, "wacom-intuos4-6x9.desc")
    a, b = new_assembler(desc), new_assembler(desc)
    assert device._TEMPLATES[id(desc)][1] is None
    assert a._history is not b._history  # type: ignore[attr-defined]
