"""Report values -> PenSamples: units, sizes, contacts, tools, the device table, replay."""

from __future__ import annotations

from pathlib import Path

import pytest

from stiction.drivers.hid import replay
from stiction.drivers.hid.descriptor import Field, Report, ReportType, parse_descriptor
from stiction.drivers.hid.devices import builtin_table, lookup, parse_table
from stiction.drivers.hid.pen import (
    CONFIDENCE,
    CONTACT_COUNT,
    CONTACT_ID,
    ERASER,
    GD_X,
    GD_Y,
    IN_RANGE,
    INVERT,
    TIP_PRESSURE,
    TIP_SWITCH,
    X_TILT,
    canonical_usage,
)
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.hid.units import degrees_per_logical, extent_m, unit_name
from stiction.drivers.sample import Tool
from stiction.errors import DeviceError


def _field(**kw: int) -> Field:
    base = dict(
        report_id=1,
        usage=GD_X,
        bit_offset=8,
        bit_size=16,
        count=1,
        logical_min=0,
        logical_max=1000,
        physical_min=0,
        physical_max=0,
        unit=0,
        unit_exponent=0,
        flags=2,
        application=0,
    )
    base.update(kw)
    return Field(**base)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("unit", "exponent", "pmax", "metres"),
    [
        (0x13, -3, 10000, 0.254),  # 10.000 in
        (0x11, -2, 2540, 0.254),  # 25.40 cm
        (0x11, 0, 25, 0.25),  # 25 cm
        (0x13, 0, 10, 0.254),
    ],
)
def test_length_units(unit: int, exponent: int, pmax: int, metres: float) -> None:
    f = _field(unit=unit, unit_exponent=exponent, physical_max=pmax)
    assert extent_m(f) == pytest.approx(metres)


@pytest.mark.parametrize("unit", [0, 0x33, 0x12, 0x14, 0x1001, 0x101, 0xE111])
def test_non_lengths_give_no_size(unit: int) -> None:
    assert extent_m(_field(unit=unit, physical_max=100)) is None


def test_physical_zero_means_logical() -> None:
    assert extent_m(_field(unit=0x11, logical_max=500)) == pytest.approx(5.0)


def test_tilt_units() -> None:
    assert degrees_per_logical(_field(unit=0x14, logical_min=-90, logical_max=90)) == 1.0
    rad = _field(
        unit=0x12,
        unit_exponent=-2,
        logical_min=-157,
        logical_max=157,
        physical_min=-157,
        physical_max=157,
    )
    assert degrees_per_logical(rad) == pytest.approx(0.573, rel=1e-3)
    assert degrees_per_logical(_field(logical_min=-127, logical_max=127)) == 1.0


def test_unit_names() -> None:
    assert [unit_name(u) for u in (0, 0x11, 0x13, 0x33, 0x14, 0x1001)] == [
        "none",
        "cm",
        "in",
        "in^3",
        "deg",
        "0x1001",
    ]


def test_wacom_vendor_page_reads_as_digitizer() -> None:
    assert canonical_usage(0xFF0D0130) == GD_X
    assert canonical_usage(0xFF0D0131) == GD_Y
    assert canonical_usage(0xFF0D0042) == TIP_SWITCH
    assert canonical_usage(0x00090001, {0x00090001: TIP_SWITCH}) == TIP_SWITCH


def _encode(report: Report, values: dict[tuple[int, int], int]) -> bytes:
    """Set (contact ordinal, canonical usage) values in a report, by the fields' bit positions."""
    groups: list[int] = []
    for f in report.fields:
        if canonical_usage(f.usage) == GD_X and f.group not in groups:
            groups.append(f.group)
    acc = report.report_id
    seen: set[tuple[int, int]] = set()
    for f in report.fields:
        if f.constant:
            continue
        usage = canonical_usage(f.usage)
        key = (groups.index(f.group) if f.group in groups else -1, usage)
        if key in values and key not in seen:
            seen.add(key)
            acc |= (values[key] & ((1 << f.bit_size) - 1)) << f.bit_offset
        elif (-1, usage) in values and (-1, usage) not in seen:
            seen.add((-1, usage))
            acc |= (values[(-1, usage)] & ((1 << f.bit_size) - 1)) << f.bit_offset
    return acc.to_bytes(report.byte_size, "little")


def _touchpad(hid_data: Path) -> tuple[ReportStream, Report]:
    rec = load_recording(hid_data / "microsoft-surface-go2-typecover-touchpad.hid")
    desc = parse_descriptor(rec.descriptor)
    return ReportStream(desc, rec.name), desc.input_reports[4]


def test_multitouch_contacts_and_lift(hid_data: Path) -> None:
    stream, report = _touchpad(hid_data)
    assert stream.kind == "touchpad"
    assert stream.surface_size == pytest.approx((0.09550, 0.05309), abs=1e-5)
    two = _encode(
        report,
        {
            (0, TIP_SWITCH): 1,
            (0, CONFIDENCE): 1,
            (0, CONTACT_ID): 2,
            (0, GD_X): 0,
            (0, GD_Y): 0,
            (1, TIP_SWITCH): 1,
            (1, CONFIDENCE): 1,
            (1, CONTACT_ID): 4,
            (1, GD_X): 3012,
            (1, GD_Y): 1000,
            (-1, CONTACT_COUNT): 2,
        },
    )
    a, b = stream.feed(0.0, two)
    assert (a.contact, b.contact) == (3, 5)
    assert a.tool is Tool.FINGER and a.tip and a.in_range
    assert (a.x, a.y) == (0.0, 0.0)
    assert b.x == pytest.approx(stream.surface_size[0])  # type: ignore[index]
    # finger 2 lifts: reported once as leaving; finger 4 stays
    lift = _encode(
        report,
        {
            (0, TIP_SWITCH): 0,
            (0, CONFIDENCE): 1,
            (0, CONTACT_ID): 2,
            (1, TIP_SWITCH): 1,
            (1, CONFIDENCE): 1,
            (1, CONTACT_ID): 4,
            (1, GD_X): 3000,
            (-1, CONTACT_COUNT): 2,
        },
    )
    a, b = stream.feed(0.01, lift)
    assert (a.contact, a.tip, a.in_range) == (3, False, False)
    assert (b.contact, b.tip) == (5, True)
    # the next frame has one contact: the stale slot is not read
    one = _encode(
        report,
        {
            (0, TIP_SWITCH): 1,
            (0, CONFIDENCE): 1,
            (0, CONTACT_ID): 4,
            (0, GD_X): 2000,
            (1, TIP_SWITCH): 1,
            (1, CONTACT_ID): 2,
            (-1, CONTACT_COUNT): 1,
        },
    )
    (only,) = stream.feed(0.02, one)
    assert only.contact == 5


def test_hybrid_mode_follows_contact_count_across_reports(hid_data: Path) -> None:
    rec = load_recording(hid_data / "elan-04f3-3140-touchpad.hid")
    desc = parse_descriptor(rec.descriptor)
    stream = ReportStream(desc, rec.name)
    report = desc.input_reports[4]  # one finger per report

    def finger(cid: int, count: int) -> bytes:
        values = {(0, TIP_SWITCH): 1, (0, CONFIDENCE): 1, (0, CONTACT_ID): cid}
        return _encode(report, {**values, (0, GD_X): 100 * cid, (-1, CONTACT_COUNT): count})

    assert [s.contact for s in stream.feed(0.0, finger(0, 3))] == [1]
    assert [s.contact for s in stream.feed(0.0, finger(1, 0))] == [2]
    assert [s.contact for s in stream.feed(0.0, finger(2, 0))] == [3]
    assert stream.feed(0.0, finger(3, 0)) == []  # beyond the announced three


def test_palm_is_not_a_contact(hid_data: Path) -> None:
    stream, report = _touchpad(hid_data)
    palm = _encode(
        report,
        {(0, TIP_SWITCH): 1, (0, CONFIDENCE): 0, (0, CONTACT_ID): 1, (-1, CONTACT_COUNT): 1},
    )
    assert stream.feed(0.0, palm) == []


def test_touchscreen_with_pen_keeps_pen_and_fingers_apart(hid_data: Path) -> None:
    rec = load_recording(hid_data / "goodix-27c6-0e00-usi-pen.hid")
    desc = parse_descriptor(rec.descriptor)
    stream = ReportStream(desc, rec.name)
    pen_ids = [rid for rid, m in stream.mappings.items() if any(not c.finger for c in m.contacts)]
    finger_ids = [rid for rid, m in stream.mappings.items() if all(c.finger for c in m.contacts)]
    assert pen_ids and finger_ids
    pen = desc.input_reports[pen_ids[0]]
    data = _encode(
        pen,
        {
            (0, TIP_SWITCH): 1,
            (0, IN_RANGE): 1,
            (0, GD_X): 10,
            (0, TIP_PRESSURE): 4095,
            (0, INVERT): 1,
        },
    )
    (s,) = stream.feed(0.0, data)
    assert s.contact == 0 and s.tool is Tool.ERASER and s.tip
    assert s.pressure == pytest.approx(
        4095 / next(f.logical_max for f in pen.fields if f.usage == TIP_PRESSURE)
    )


def test_pen_hover_touch_leave_and_tilt(hid_data: Path) -> None:
    rec = load_recording(hid_data / "ugee-m708-v2.hid")
    desc = parse_descriptor(rec.descriptor)
    stream = ReportStream(desc, rec.name)
    report = desc.input_reports[7]
    hover = _encode(report, {(0, IN_RANGE): 1, (0, GD_X): 50794, (0, X_TILT): -40})
    (h,) = stream.feed(0.0, hover)
    assert (h.tip, h.in_range, h.tool, h.tilt_x) == (False, True, Tool.PEN, -40.0)
    assert h.x == pytest.approx(0.2539746)
    (t,) = stream.feed(
        0.01, _encode(report, {(0, IN_RANGE): 1, (0, TIP_SWITCH): 1, (0, ERASER): 1})
    )
    assert t.tip and t.tool is Tool.ERASER
    (gone,) = stream.feed(0.02, _encode(report, {}))
    assert (gone.tip, gone.in_range) == (False, False)
    assert stream.feed(0.03, _encode(report, {})) == []  # nothing in range: silence


def test_intuos_vendor_page_descriptor_is_a_pen(hid_data: Path) -> None:
    rec = load_recording(hid_data / "wacom-intuos-s-ctl4100.hid")
    stream = ReportStream(parse_descriptor(rec.descriptor), rec.name)
    assert stream.kind == "pen"
    assert stream.surface_size == pytest.approx((0.152, 0.095))  # Intuos S: 152 x 95 mm


def test_recordings_replay_to_samples(hid_data: Path) -> None:
    src = replay(hid_data / "xp-pen-artist-10s.hid", realtime=False)
    samples = list(src.samples())
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    assert [s.t for s in samples] == [e.t for e in rec.events]
    stats = src.stats()
    assert (stats["reports"], stats["samples"]) == (3587, 3587)
    # this pen reports a few points beyond its declared area: kept on it, counted
    assert 0 < stats["clamped_positions"] < 20
    assert any(s.tip for s in samples) and any(not s.in_range for s in samples)
    assert src.surface_size == pytest.approx((0.2169414, 0.1355852))


def test_missing_size_names_the_device_and_the_fix(hid_data: Path) -> None:
    path = hid_data / "huion-hs610.hid"
    with pytest.raises(DeviceError) as err:
        replay(path, realtime=False)
    msg = str(err.value)
    assert "HUION Huion Tablet (256c:006d" in msg
    assert "hid-devices.toml" in msg and "size_mm = [width, height]" in msg
    src = replay(path, realtime=False, size_m=(0.254, 0.15875))
    samples = list(src.samples())
    assert src.surface_size == (0.254, 0.15875)
    assert max(s.x for s in samples) <= 0.254 and len(samples) > 2000


def test_device_table_supplies_layout_and_size(hid_data: Path) -> None:
    src = replay(hid_data / "xp-pen-deco-03.hid", realtime=False)
    samples = list(src.samples())
    assert src.surface_size == pytest.approx((0.254, 0.1427))
    assert len(samples) == 3646 and any(s.tip for s in samples)
    assert any(s.pressure and s.pressure > 0.5 for s in samples)


def test_builtin_table_is_valid_and_sourced() -> None:
    table = builtin_table()
    assert len(table) >= 4
    assert all(e.source for e in table.values())
    assert lookup(0x256C, 0x006D) is not None and lookup(0x256C, 0x006D).init  # type: ignore[union-attr]
    assert lookup(0x1234, 0x5678) is None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[[device]]\nid = "12:34:56"\nsource = "x"', "vvvv:pppp"),
        ('[[device]]\nid = "zzzz:0001"\nsource = "x"', "not a hex number"),
        ('[[device]]\nid = "0001:0001"', "source"),
        ('[[device]]\nid = "0001:0001"\nsource = "x"\nsize_mm = [1]', "size_mm"),
        ('[[device]]\nid = "0001:0001"\nsource = "x"\ninit = "magic"', "unknown init"),
        ('[[device]]\nid = "1:1"\nsource = "x"\n[[device]]\nid = "1:1"\nsource = "y"', "twice"),
        ("[[device]\n", "devices.toml"),
    ],
)
def test_bad_table_entries_are_refused(text: str, message: str) -> None:
    with pytest.raises(DeviceError, match=message):
        parse_table(text)


def test_report_type_enum_is_complete() -> None:
    assert {t.value for t in ReportType} == {"input", "output", "feature"}


def test_table_size_overrides_a_wrong_descriptor(hid_data: Path) -> None:
    rec = load_recording(hid_data / "veikk-s640.hid")
    desc = parse_descriptor(rec.descriptor)
    assert ReportStream(desc, rec.name).surface_size == pytest.approx((0.020828, 0.0279654))
    fixed = ReportStream(desc, rec.name, None, lookup(rec.vid, rec.pid))
    assert fixed.surface_size == pytest.approx((0.1524, 0.1016))
    user = ReportStream(desc, rec.name, (0.15, 0.1), lookup(rec.vid, rec.pid))
    assert user.surface_size == (0.15, 0.1)  # the user's size wins over the table's


def test_eraser_bit_counts_only_with_invert(hid_data: Path) -> None:
    """Microsoft's pen protocol: Eraser is the tip switch of the inverted pen."""
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")  # has Tip, Eraser and Invert
    desc = parse_descriptor(rec.descriptor)
    stream = ReportStream(desc, rec.name)
    report = desc.input_reports[7]
    (s,) = stream.feed(0.0, _encode(report, {(0, IN_RANGE): 1, (0, ERASER): 1}))
    assert (s.tip, s.tool) == (False, Tool.PEN)
    (s,) = stream.feed(0.01, _encode(report, {(0, IN_RANGE): 1, (0, ERASER): 1, (0, INVERT): 1}))
    assert (s.tip, s.tool) == (True, Tool.ERASER)
    (s,) = stream.feed(0.02, _encode(report, {(0, IN_RANGE): 1, (0, INVERT): 1}))
    assert (s.tip, s.tool) == (False, Tool.ERASER)  # eraser end hovering


@pytest.mark.parametrize(
    ("name", "touching", "hovering"),
    [("huion-580", 275, 1422), ("yiynova-mvp20u-rh", 885, 850)],
)
def test_uclogic_inverted_in_range_from_the_table(
    hid_data: Path, name: str, touching: int, hovering: int
) -> None:
    """These record the pen touching with the in-range bit clear: it is inverted (table fix-up)."""
    src = replay(hid_data / f"{name}.hid", realtime=False)
    samples = list(src.samples())
    assert sum(s.tip for s in samples) == touching
    assert sum(s.in_range and not s.tip for s in samples) == hovering
    assert all(s.in_range for s in samples if s.tip)


@pytest.mark.parametrize("name", ["contour-rollermouse-red", "microsoft-keyboard-045e-0773"])
def test_devices_without_pen_or_touch_reports_are_refused(hid_data: Path, name: str) -> None:
    with pytest.raises(DeviceError, match="no pen, touch screen or touchpad report"):
        replay(hid_data / f"{name}.hid", realtime=False)
