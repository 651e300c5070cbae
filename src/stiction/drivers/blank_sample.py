"""PenSamples built without the frozen dataclass's per-field cost, for the input hot paths.

A PenSample is a frozen dataclass with slots: its __init__ sets each of its
eleven fields through ``object.__setattr__``, about 1 us per sample -- more
than decoding the report or the evdev frame it comes from. `BlankSample`
has the very same slots in the same order, so a hot path (the HID report
path in hid/report_code.py, the evdev conversion in evdev/units.py) fills
one with plain attribute stores and then makes it a PenSample by assigning
``__class__``, which Python allows between classes of the same layout. That
costs a fifth as much, and what comes out is an ordinary frozen PenSample:
equal, hashable and immutable like any other (tests/hid/test_hid_report_code.py
and tests/evdev/test_evdev_frames.py check type, equality and immutability).

Use::

    s = BlankSample()  # (no __init__: a quarter cheaper than object.__new__)
    s.t = ...  # every field of PenSample, none left out
    s.__class__ = PenSample
"""

from __future__ import annotations

from stiction.drivers.sample import PenSample

FIELDS: tuple[str, ...] = PenSample.__slots__
"""PenSample's fields in declaration order (its slots)."""


class BlankSample:
    """PenSample's memory layout and nothing else (see the module doc)."""

    __slots__ = FIELDS


def _check() -> None:
    """Refuse at import, not at the first report, if the two layouts ever part."""
    s = BlankSample()
    for name in FIELDS:
        setattr(s, name, None)
    s.__class__ = PenSample  # type: ignore[assignment]  # TypeError if the layouts differ


_check()
