"""Huion / UC-Logic full-resolution mode: generated descriptors, report fix-up, proximity."""

from __future__ import annotations

import pytest
from hidtools.hid import ReportDescriptor as HtDescriptor

from stiction.drivers.hid import uclogic
from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.hid.usb_init import HuionParams

V2 = HuionParams(200, 50800, 31750, 8191, 5080)
V1 = HuionParams(100, 20000, 12500, 2047, 2000)


@pytest.mark.parametrize("params", [V1, V2])
def test_generated_descriptors_parse_the_same_in_hid_tools(params: HuionParams) -> None:
    raw = uclogic.pen_descriptor(params)
    mine = parse_descriptor(raw)
    ht = HtDescriptor.from_bytes(list(raw))
    rid = uclogic.PEN_V2_ID if params.index == 200 else uclogic.PEN_V1_ID
    assert list(mine.input_reports) == list(ht.input_reports) == [rid]
    fields = mine.input_reports[rid].fields
    ht_fields = list(ht.input_reports[rid])
    assert [(f.usage, f.bit_offset, f.bit_size, f.logical_max, f.physical_max) for f in fields] == [
        (h.usage, h.start, h.size, h.logical_max, h.physical_max) for h in ht_fields
    ]
    size = ReportStream(mine, "huion").surface_size
    assert size == pytest.approx(params.size_m, rel=1e-5)


def _v2(x: int, y: int, p: int, flags: int = 0x81) -> bytes:
    """A raw v2 pen report: X/Y low 16 bits, pressure, X/Y high bytes, tilt."""
    low = [x & 255, (x >> 8) & 255, y & 255, (y >> 8) & 255, p & 255, p >> 8]
    return bytes([8, flags, *low, x >> 16, y >> 16, 0x05, 0xFB])


def test_v2_fragmented_coordinates_are_reassembled() -> None:
    stream = ReportStream(
        parse_descriptor(uclogic.pen_descriptor(V2)), "huion", None, None, uclogic.fixup_v2
    )
    (s,) = stream.feed(0.0, _v2(50800, 31750, 8191))
    assert (s.x, s.y) == pytest.approx(V2.size_m)
    assert (s.tip, s.in_range, s.pressure, s.tilt_x, s.tilt_y) == (True, True, 1.0, 5.0, -5.0)
    (s,) = stream.feed(0.01, _v2(0x00ABCD, 0x001234, 100, flags=0x80))
    assert s.x == pytest.approx(0x00ABCD / 50800 * 0.254)
    assert s.y == pytest.approx(0x001234 / 31750 * 0.15875)
    assert s.tip is False and s.in_range
    # a large pen display: the high bytes carry real bits
    big = HuionParams(200, 121000, 68100, 8191, 5080)
    wide = ReportStream(
        parse_descriptor(uclogic.pen_descriptor(big)), "kamvas", None, None, uclogic.fixup_v2
    )
    (s,) = wide.feed(0.0, _v2(0x012345, 0x010203, 0))
    assert s.x == pytest.approx(0x012345 / 121000 * big.size_m[0], rel=1e-5)
    assert s.y == pytest.approx(0x010203 / 68100 * big.size_m[1], rel=1e-5)
    assert stream.feed(0.02, _v2(1, 1, 1, flags=0xA0)) == []  # frame-button report
    assert stream.feed(0.03, _v2(1, 1, 1)[:6]) == []  # short
    assert stream.stats["ignored"] == 1 and stream.stats["short_reports"] == 1


def test_v1_in_range_bit_is_inverted() -> None:
    stream = ReportStream(
        parse_descriptor(uclogic.pen_descriptor(V1)), "huion", None, None, uclogic.fixup_v1
    )
    near = bytes([7, 0x01, 0x10, 0x27, 0x88, 0x13, 0xFF, 0x07])  # bit 6 clear: in range
    (s,) = stream.feed(0.0, near)
    assert (s.tip, s.in_range, s.pressure) == (True, True, 1.0)
    assert s.x == pytest.approx(10000 / 20000 * 0.254)
    (gone,) = stream.feed(0.01, bytes([7, 0x40, 0, 0, 0, 0, 0, 0]))
    assert gone.in_range is False


def test_v2_pen_leaves_after_100_ms_of_silence() -> None:
    stream = ReportStream(
        parse_descriptor(uclogic.pen_descriptor(V2)),
        "huion",
        None,
        None,
        uclogic.fixup_v2,
        uclogic.PROXIMITY_TIMEOUT_S,
    )
    (s,) = stream.feed(1.0, _v2(1000, 2000, 0, flags=0x80))
    assert stream.idle(1.05) == []
    (gone,) = stream.idle(1.2)
    assert (gone.t, gone.x, gone.y, gone.in_range, gone.tip) == (1.2, s.x, s.y, False, False)
    assert stream.idle(1.5) == []  # once
    (back,) = stream.feed(2.0, _v2(1000, 2000, 0, flags=0x80))
    assert back.in_range


def test_tablets_with_an_in_range_bit_never_time_out() -> None:
    stream = ReportStream(parse_descriptor(uclogic.pen_descriptor(V1)), "huion")
    stream.feed(0.0, bytes([7, 0x41, 0, 0, 0, 0, 0, 0]))
    assert stream.idle(10.0) == []
