"""PenSamples built without the frozen dataclass's per-field cost, for the input hot paths.

A PenSample is a frozen dataclass with slots: its __init__ sets each of its
eleven fields through ``object.__setattr__``, about 1 us per sample -- more
than decoding the report or the evdev frame it comes from. `BlankSample`
is a subclass of PenSample that adds no slots and takes back object's own
``__init__``, ``__setattr__`` and ``__delattr__``, so a hot path (the HID
report path in hid/report_code.py, the evdev conversion in evdev/units.py,
the generated evdev readers) fills one with plain attribute stores and then
makes it a PenSample by assigning ``__class__``, which Python allows between
classes of the same layout. Being a subclass that adds nothing is what makes
that assignment cheap: CPython accepts a change between a type and its base
as soon as it sees the child adds nothing to the layout, where two unrelated
classes of the same layout have their slot-name tuples compared field by
field, at every sample: about half of that assignment's cost
(docs/evdev.md). The whole costs a fifth of the keyword __init__, and what
comes out is an ordinary frozen PenSample:
equal, hashable and immutable like any other (tests/hid/test_hid_report_code.py
and tests/evdev/test_evdev_frames.py check type, equality and immutability).

Use::

    s = BlankSample()  # (object's __init__: nothing per field)
    s.t = ...  # every field of PenSample, none left out
    s.__class__ = PenSample
"""

from __future__ import annotations

from stiction.drivers.sample import PenSample

FIELDS: tuple[str, ...] = PenSample.__slots__
"""PenSample's fields in declaration order (its slots)."""


class BlankSample(PenSample):
    """A PenSample being filled in (see the module doc). None may outlive the code
    that made it: every one becomes a PenSample before it is handed out."""

    __slots__ = ()
    __init__ = object.__init__  # type: ignore[assignment]
    __setattr__ = object.__setattr__  # type: ignore[assignment]
    __delattr__ = object.__delattr__  # type: ignore[assignment]


def _check() -> None:
    """Refuse at import, not at the first report, if the two layouts ever part."""
    s = BlankSample()
    for name in FIELDS:
        setattr(s, name, None)
    s.__class__ = PenSample  # type: ignore[assignment]  # TypeError if the layouts differ


_check()
