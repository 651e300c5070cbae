"""A hovering eraser end is not a touch once a family's report is normalised.

HID's Eraser usage is the eraser end's tip switch; the end being in range is
Invert (Microsoft's pen protocol, which pen.py follows). The reports are
copied from the dump in OpenTabletDriver issue #3850 (XP-Pen Artist 16 2nd
Gen, 28bd:094c, vendor mode), read by the ``xp-pen`` family; the Graphire
ones are built byte by byte from the layout in families.py.
"""

from __future__ import annotations

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.families import Geometry, descriptor, fixup
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.sample import PenSample, Tool

ARTIST16 = Geometry(68198, 38362, 8191, 340.99, 191.81)


def _read(family: str, geom: Geometry, reports: list[bytes]) -> list[PenSample]:
    stream = ReportStream(parse_descriptor(descriptor(geom)), "t", None, None, fixup(family, geom))
    return [s for i, r in enumerate(reports) for s in stream.feed(i / 100, r)]


def test_the_dumped_eraser_hovers_then_presses_then_leaves() -> None:
    hover, press, gone = _read(
        "xp-pen",
        ARTIST16,
        [
            bytes.fromhex("02a86c4eae36000007170000"),  # eraser end in range, no tip
            bytes.fromhex("02a96c4e2b38a00a080a0000"),  # eraser end pressing
            bytes.fromhex("02c02c4eb837000006240000"),  # gone
        ],
    )
    assert (hover.in_range, hover.tip, hover.tool) == (True, False, Tool.ERASER)
    assert (press.tip, press.tool) == (True, Tool.ERASER)
    assert press.pressure is not None and press.pressure > 0.3
    assert not gone.in_range and not gone.tip


def test_a_graphire_eraser_in_range_without_its_tip_is_not_touching() -> None:
    geom = Geometry(10208, 7424, 511, 102.0, 74.0)
    # Report 2, byte 1: bit 7 in range, bits 5-6 the tool (1: eraser), bit 0 the tip.
    hover = bytes([2, 0x80 | 0x20, 0x10, 0x27, 0x20, 0x1C, 0, 0])
    press = bytes([2, 0x80 | 0x20 | 0x01, 0x10, 0x27, 0x20, 0x1C, 200, 0])
    a, b = _read("wacom-graphire", geom, [hover, press])
    assert (a.tip, a.tool) == (False, Tool.ERASER)
    assert (b.tip, b.tool) == (True, Tool.ERASER)
