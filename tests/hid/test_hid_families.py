"""Vendor report families: the real PenStation recording, and each documented layout.

Only `wacom-graphire` has a real recording in ../shared/data/hid
(wacom-penpartner.hid, 056a:0061, a Wacom PenStation2 sold as PenPartner).
The other families are tested on reports built byte by byte from the layout
their module docstring describes (Linux wacom_wac.c), as the test names say.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import lookup, parse_table
from stiction.drivers.hid.families import (
    FAMILIES,
    NORMAL_ID,
    Geometry,
    PenState,
    descriptor,
    fixup,
)
from stiction.drivers.hid.pen import build_mappings
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.hid.units import extent_m
from stiction.errors import DeviceError

GEOM = Geometry(max_x=15200, max_y=9500, max_pressure=1023, width_mm=152.0, height_mm=95.0)


def _read(family: str, geom: Geometry = GEOM):  # type: ignore[no-untyped-def]
    return FAMILIES[family](geom)


def test_penstation_recording_gives_contacts_on_the_kernels_surface(hid_data: Path) -> None:
    rec = load_recording(hid_data / "wacom-penpartner.hid")
    entry = lookup(rec.vid, rec.pid)
    assert entry is not None and entry.family == "wacom-graphire"
    stream = ReportStream(parse_descriptor(rec.descriptor), rec.name, None, entry)
    assert stream.surface_size == pytest.approx((0.065, 0.0464))
    samples = [s for ev in rec.events for s in stream.feed(ev.t, ev.data)]
    assert len(samples) > 500
    assert all(0 <= s.x <= 0.065 and 0 <= s.y <= 0.0464 for s in samples)
    tips = [s for s in samples if s.tip]
    assert tips and all(s.in_range for s in tips)
    assert all(s.pressure is not None and s.pressure > 0 for s in tips)
    # The all-zero report 99 the tablet interleaves is not a pen report.
    assert stream.stats["ignored"] == sum(1 for ev in rec.events if ev.data[0] == 0x63)
    assert stream.stats["short_reports"] == stream.stats["unknown_report_id"] == 0


def test_generated_descriptor_declares_the_catalogue_size() -> None:
    desc = parse_descriptor(descriptor(GEOM))
    (report,) = desc.input_reports.values()
    assert report.report_id == NORMAL_ID
    (mapping,) = build_mappings(desc, "t", None).values()
    c = mapping.contacts[0]
    assert (c.width_m, c.height_m) == pytest.approx((0.152, 0.095))
    x = next(f for f in report.fields if f.usage == 0x00010030)
    assert extent_m(x) == pytest.approx(0.152)


def test_graphire_layout_pen_eraser_mouse_and_out_of_range() -> None:
    read = _read("wacom-graphire")
    pen = read(bytes([2, 0x80 | 0x01 | 0x02, 0x34, 0x12, 0x78, 0x06, 0x10, 0x03]))
    assert pen == PenState(0x1234, 0x0678, 0x310, True, True, True, False, False)
    eraser = read(bytes([2, 0x80 | 0x20, 1, 0, 2, 0, 0, 0]))
    assert eraser is not None and eraser.eraser and not eraser.tip
    assert read(bytes([2, 0x80 | 0x40, 1, 0, 2, 0, 0, 0])) is None  # a mouse
    gone = read(bytes([2, 0x00, 1, 0, 2, 0, 0, 0]))
    assert gone is not None and not gone.in_range
    assert read(bytes([99, 0, 0, 0, 0, 0, 0, 0])) is None


def test_penpartner_layout_reports_1_and_2() -> None:
    read = _read("wacom-penpartner", Geometry(5040, 3780, 255, 126.0, 94.5))
    r1 = read(bytes([1, 0x10, 0x02, 0x20, 0x03, 0x80 | 0x40, 0x10]))
    assert r1 == PenState(0x0210, 0x0320, 16 + 127, True, True, True)
    assert read(bytes([1, 0, 0, 0, 0, 0x80, 0x81])).tip is False  # type: ignore[union-attr]
    out = read(bytes([1, 0, 0, 0, 0, 0x00, 0]))
    assert out is not None and not out.in_range
    r2 = read(bytes([2, 0x10, 0x02, 0x20, 0x03, 0x00, 0xB0]))  # pressure -80: not down
    assert r2 is not None and r2.in_range and not r2.tip and r2.pressure == 47


def test_bpt_layout_keeps_the_last_position_while_only_in_range() -> None:
    read = _read("wacom-bpt")
    down = read(bytes([2, 0x80 | 0x40 | 0x20 | 0x01, 0x10, 0x27, 0x20, 0x1C, 0x00, 0x02, 0]))
    assert down == PenState(0x2710, 0x1C20, 0x200, True, True)
    hover = read(bytes([2, 0x80, 0, 0, 0, 0, 0, 0, 0]))  # in range, position not valid
    assert hover == PenState(0x2710, 0x1C20, 0, False, True)
    eraser = read(bytes([2, 0x80 | 0x40 | 0x08, 1, 0, 1, 0, 0, 0, 0]))
    assert eraser is not None and eraser.eraser
    assert not read(bytes([2, 0, 0, 0, 0, 0, 0, 0, 0])).in_range  # type: ignore[union-attr]


def _intuos_general(x: int, y: int, p: int, buttons: int = 0) -> bytes:
    return bytes(
        [
            2,
            buttons | (p & 1),
            (x >> 9) & 0xFF,
            (x >> 1) & 0xFF,
            (y >> 9) & 0xFF,
            (y >> 1) & 0xFF,
            (p >> 3) & 0xFF,
            ((p >> 1) & 3) << 6,
            0,
            ((x & 1) << 1) | (y & 1),
        ]
    )


@pytest.mark.parametrize(("tool_id", "eraser"), [(0x822, False), (0x82A, True), (0x852, False)])
def test_intuos_layout_enter_general_exit(tool_id: int, eraser: bool) -> None:
    read = _read("wacom-intuos", Geometry(44704, 27940, 2047, 223.5, 139.7))
    assert read(_intuos_general(100, 100, 500)) is None  # no tool announced yet
    enter = bytes([2, 0xC2, tool_id >> 4, (tool_id & 0xF) << 4, 0, 0, 0, 0, 0, 0])
    assert read(enter) is None
    s = read(_intuos_general(40001, 20000, 1500, buttons=0x02))
    assert s == PenState(40001, 20000, 1500, True, True, True, False, eraser)
    light = read(_intuos_general(40001, 20000, 9))
    assert light is not None and not light.tip and light.in_range
    out = read(bytes([2, 0x80, 0, 0, 0, 0, 0, 0, 0, 0]))
    assert out is not None and not out.in_range
    assert read(_intuos_general(1, 1, 500)) is None


def test_intuos_1024_levels_and_intuos1_half_resolution() -> None:
    enter = bytes([2, 0xC2, 0x82, 0x20, 0, 0, 0, 0, 0, 0])
    read = _read("wacom-intuos", Geometry(15200, 9500, 1023, 152.0, 95.0))
    read(enter)
    assert read(_intuos_general(15000, 9000, 1000)).pressure == 500  # type: ignore[union-attr]
    read1 = _read("wacom-intuos1", Geometry(12700, 10360, 1023, 127.0, 103.6))
    read1(enter)
    s = read1(_intuos_general(20000, 16000, 1000))
    assert s is not None and (s.x, s.y) == (10000, 8000)


@pytest.mark.parametrize("family", sorted(FAMILIES))
@given(data=st.binary(max_size=24))
def test_any_bytes_give_nothing_or_a_report_within_the_declared_ranges(
    family: str, data: bytes
) -> None:
    fix = fixup(family, GEOM)
    out = fix(data)
    if out is None:
        return
    desc = parse_descriptor(descriptor(GEOM))
    stream_values = build_mappings(desc, "t", None)[NORMAL_ID].decoder.decode(out)
    assert len(out) == 12 and out[0] == NORMAL_ID
    assert all(isinstance(v, int) for v in stream_values)
    assert int.from_bytes(out[2:6], "little") <= GEOM.max_x
    assert int.from_bytes(out[6:10], "little") <= GEOM.max_y
    assert int.from_bytes(out[10:12], "little") <= GEOM.max_pressure


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('family = "wacom-nope"', "unknown family"),
        ('family = "wacom-graphire"\nmax_y = 10\nmax_pressure = 10\nsize_mm = [1, 1]', "max_x"),
        ('family = "wacom-graphire"\nmax_x = 10\nmax_y = 10\nmax_pressure = 10', "size_mm"),
        (
            'family = "wacom-graphire"\nmax_x = -1\nmax_y = 1\nmax_pressure = 1\nsize_mm = [1, 1]',
            "max_x",
        ),
    ],
)
def test_a_family_entry_without_its_ranges_is_refused(extra: str, message: str) -> None:
    text = f'[[device]]\nid = "056a:0099"\nsource = "test"\n{extra}\n'
    with pytest.raises(DeviceError, match=message):
        parse_table(text, "t.toml")


def test_ptu_layout_pen_and_eraser() -> None:
    read = _read("wacom-ptu", Geometry(20480, 15360, 511, 204.8, 153.6))
    pen = read(bytes([2, 0x20 | 0x01 | 0x10, 0x00, 0x10, 0x00, 0x08, 0xFF, 0x01]))
    assert pen == PenState(0x1000, 0x0800, 0x1FF, True, True, False, True, False)
    eraser = read(bytes([2, 0x20 | 0x04 | 0x08, 1, 0, 1, 0, 5, 0]))
    assert eraser is not None and eraser.eraser and eraser.tip
    assert not read(bytes([2, 0, 1, 0, 1, 0, 0, 0])).in_range  # type: ignore[union-attr]


def _pl_report(x: int, y: int, p: int, b4: int = 0) -> bytes:
    raw = p & 0x1FF  # 9-bit two's complement: byte 7 holds bits 1-8, byte 4 bit 2 bit 0
    return bytes(
        [
            2,
            0x40 | ((x >> 14) & 3),
            (x >> 7) & 0x7F,
            x & 0x7F,
            b4 | ((y >> 14) & 3) | ((raw & 1) << 2),
            (y >> 7) & 0x7F,
            y & 0x7F,
            (raw >> 1) & 0xFF,
        ]
    )


def test_pl_layout_seven_bit_coordinates_and_centred_pressure() -> None:
    read = _read("wacom-pl", Geometry(7220, 5780, 255, 361.0, 289.0))
    s = read(_pl_report(7000, 5000, -100, b4=0x08))
    assert s is not None and (s.x, s.y) == (7000, 5000)
    assert s.pressure == 28 and s.tip and not s.eraser
    held = read(_pl_report(7000, 5000, 0, b4=0x20))  # pen already chosen: button 2 held
    assert held is not None and held.barrel2 and not held.eraser


def test_otd_parsers_map_to_families_with_the_kernels_exceptions() -> None:
    from stiction.drivers.hid.families import family_for

    assert family_for("GraphireReportParser", "Wacom CTE-430", 0x056A, 0x13) == "wacom-graphire"
    assert family_for("IntuosReportParser", "Wacom CTL-480", 0x056A, 0x30E) == "wacom-bpt"
    assert family_for("IntuosReportParser", "Wacom CTE-460", 0x056A, 0x6A) == "wacom-graphire"
    assert family_for("IntuosV1ReportParser", "Wacom GD-0608-U", 0x056A, 0x21) == "wacom-intuos1"
    assert family_for("IntuosV1ReportParser", "Wacom PTH-650", 0x056A, 0x27) == "wacom-intuos"
    assert family_for("XP_PenReportParser", "XP-Pen Deco 01", 0x28BD, 0x42) is None
