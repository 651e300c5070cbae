"""HID descriptors of devices stiction has never seen: whole classes, not files.

Each class is a descriptor built item by item (the shapes no shared capture
has, but a firmware could send), read through `ReportStream` -- the daemon's
decoding path, whose generated feed a test elsewhere holds equal to
`ContactTracker` -- and, where a class decides what `stiction devices` lists,
through the production hidraw backend under umockdev. The expectation: the
device is read on its whole surface, or refused in one line that names it
and says what to do.
"""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from umockdev_hidraw import write_mock

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.facts import describe_device
from stiction.drivers.hid.pen import ContactTracker, bits_needed, build_mappings
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.hid.units import tilt_map
from stiction.errors import DeviceError

HELPER = Path(__file__).resolve().parent / "hidraw_reader_helper.py"


# -- a descriptor builder: short items only, the numbers in the fewest bytes ---------


def item(tag: int, value: int | None = None) -> bytes:
    """A short item; `tag` is the prefix byte with a size of 0."""
    if value is None:
        return bytes([tag])
    for size_code, fmt in ((1, "<b"), (2, "<h"), (3, "<i")):
        try:
            return bytes([tag | size_code]) + struct.pack(fmt, value)
        except struct.error:
            continue
    raise ValueError(value)


PAGE, USAGE, COLLECTION, END = 0x04, 0x08, 0xA0, 0xC0
LMIN, LMAX, PMIN, PMAX, UEXP, UNIT = 0x14, 0x24, 0x34, 0x44, 0x54, 0x64
SIZE, COUNT, RID, INPUT = 0x74, 0x94, 0x84, 0x80
INCH, CM, DEGREES, RADIANS = 0x13, 0x11, 0x14, 0x12


def field(
    page: int, usage: int, lo: int, hi: int, bits: int, *, plo: int = 0, phi: int = 0,
    unit: int = 0, exp: int = 0,
) -> bytes:  # fmt: skip
    return b"".join(
        [
            item(PAGE, page), item(USAGE, usage), item(LMIN, lo), item(LMAX, hi),
            item(PMIN, plo), item(PMAX, phi), item(UNIT, unit), item(UEXP, exp & 0xF),
            item(SIZE, bits), item(COUNT, 1), item(INPUT, 2),
        ]
    )  # fmt: skip


def flags(*usages: int) -> bytes:
    """Digitizer bits (Tip Switch, In Range, ...) padded to a byte."""
    out = item(PAGE, 0x0D) + b"".join(item(USAGE, u) for u in usages)
    out += item(LMIN, 0) + item(LMAX, 1) + item(SIZE, 1) + item(COUNT, len(usages))
    out += item(INPUT, 2)
    return out + item(SIZE, 8 - len(usages)) + item(COUNT, 1) + item(INPUT, 3)


def collection(usage: int, body: bytes, kind: int = 0) -> bytes:
    return item(PAGE, 0x0D) + item(USAGE, usage) + item(COLLECTION, kind) + body + item(END)


def pen_body(x_bits: int = 16, x_max: int = 10000, tilt: bytes = b"") -> bytes:
    """Tip Switch + In Range, X 0..x_max over 10 in, Y 0..6000 over 6 in."""
    return (
        flags(0x42, 0x32)
        + field(1, 0x30, 0, x_max, x_bits, phi=1000, unit=INCH, exp=-2)
        + field(1, 0x31, 0, 6000, 16, phi=600, unit=INCH, exp=-2)
        + tilt
    )


def pen(body: bytes, rid: int = 2) -> bytes:
    """A Digitizer/Pen application with one report."""
    return collection(0x02, item(RID, rid) + body, kind=1)


# -- position fields that cannot reach their range -----------------------------------


@pytest.mark.parametrize("bits", [0, 4, 8, 13])
def test_an_x_field_narrower_than_its_range_is_refused_naming_it(bits: int) -> None:
    """Read as declared, every position lands in a corner: 0..255 of 0..10000 on an
    8-bit X is the first 2.6 mm of a 254 mm tablet, with no warning."""
    desc = parse_descriptor(pen(collection(0x20, pen_body(x_bits=bits))))
    with pytest.raises(DeviceError, match=f"report 2's X field is {bits} bits wide but declares "
                       "logical 0..10000, which needs 14") as info:  # fmt: skip
        ReportStream(desc, "Acme Pen")
    assert str(info.value).startswith("Acme Pen: ") and "\n" not in str(info.value)
    facts = describe_device(0x1234, 0x0001, "Acme Pen", pen(collection(0x20, pen_body(bits))))
    assert facts.kind == "pen" and facts.surface_m is None and "descriptor" in str(facts.problem)


@settings(max_examples=120, deadline=None, derandomize=True)
@given(
    bits=st.integers(0, 32),
    lo=st.one_of(st.integers(-(2**31), 0), st.just(0)),
    hi=st.integers(1, 2**31 - 1),
)
def test_whatever_the_field_width_an_accepted_x_reaches_the_far_edge(
    bits: int, lo: int, hi: int
) -> None:
    body = (
        flags(0x42, 0x32)
        + field(1, 0x30, lo, hi, bits, plo=0, phi=1000, unit=INCH, exp=-2)
        + field(1, 0x31, 0, 6000, 16, phi=600, unit=INCH, exp=-2)
    )
    desc = parse_descriptor(pen(collection(0x20, body)))
    try:
        stream = ReportStream(desc, "Acme Pen")
    except DeviceError as exc:
        assert "Acme Pen" in str(exc) and "\n" not in str(exc)
        return
    # the report with X at its logical maximum: the tablet's far edge
    report = desc.input_reports[2]
    payload = int.from_bytes(bytes(report.byte_size - 1), "little")
    payload |= 0b11  # tip, in range
    x_field = next(f for f in report.fields if f.usage == 0x00010030)
    payload |= (hi & ((1 << bits) - 1)) << (x_field.bit_offset - 8)
    data = bytes([2]) + payload.to_bytes(report.byte_size - 1, "little")
    (s,) = stream.feed(0.0, data)
    assert s.x == pytest.approx(0.254)


def test_every_shared_descriptor_has_position_fields_wide_enough(hid_data: Path) -> None:
    """The rule refuses no real device (the coverage benchmark counts them too)."""
    files = sorted(hid_data.glob("*.hid")) + sorted((hid_data.parent / "coverage").glob("*.hid"))
    checked = 0
    for path in files:
        raw = next(
            (bytes.fromhex("".join(line.split()[2:])) for line in path.open() if line[:2] == "R:"),
            None,
        )
        if raw is None:
            continue
        for rep in parse_descriptor(raw).input_reports.values():
            for f in rep.fields:
                if f.usage in (0x00010030, 0x00010031) and f.variable and not f.constant:
                    assert f.bit_size >= bits_needed(f), (path.name, f)
                    checked += 1
    assert checked > 300


def test_a_broken_touch_report_beside_a_good_pen_leaves_the_pen_readable() -> None:
    """One input device per kind, as the kernel makes them: a touch screen whose X
    cannot be read costs the node its touch, not its pen (and the reverse)."""
    narrow_touch = _fingers(1, contact_id=True).replace(
        field(1, 0x30, 0, 4000, 16, phi=400, unit=CM, exp=-1),
        field(1, 0x30, 0, 4000, 8, phi=400, unit=CM, exp=-1),
    )
    good_pen = pen(collection(0x20, pen_body()))
    stream = ReportStream(parse_descriptor(good_pen + narrow_touch), "Acme Display")
    assert stream.kind == "pen" and stream.surface_size == pytest.approx((0.254, 0.1524))
    narrow_pen = pen(collection(0x20, pen_body(x_bits=8)))
    stream = ReportStream(parse_descriptor(narrow_pen + _fingers(1, True)), "Acme Display")
    assert stream.kind == "touchscreen" and stream.surface_size == pytest.approx((0.4, 0.3))
    with pytest.raises(DeviceError, match="X field is 8 bits wide"):
        ReportStream(parse_descriptor(narrow_pen + pen(collection(0x20, pen_body()), 5)), "A")


def test_a_touch_interface_without_a_size_does_not_take_the_catalogues_pen_area() -> None:
    """OpenTabletDriver's sizes are pen areas: the Wacom PTH-660's (224 x 148 mm) was
    given to a touch interface of its id that declared no unit; evdev never did."""
    unitless = _fingers(2, contact_id=True).replace(
        field(1, 0x30, 0, 4000, 16, phi=400, unit=CM, exp=-1), field(1, 0x30, 0, 4000, 16)
    )
    facts = describe_device(0x056A, 0x0357, "Wacom Intuos Pro M Finger", unitless)
    assert facts.kind == "touchscreen" and facts.surface_m is None
    assert "no physical size" in str(facts.problem)
    # the same id's pen interface without a size still takes it
    pen_facts = describe_device(0x056A, 0x0357, "Wacom Intuos Pro M Pen", pen(
        collection(0x20, flags(0x42, 0x32) + field(1, 0x30, 0, 44800, 16)
                   + field(1, 0x31, 0, 29600, 16))
    ))  # fmt: skip
    assert pen_facts.size_from == "catalogue" and pen_facts.surface_m == pytest.approx(
        (0.224, 0.148)
    )


# -- several contacts in one report ---------------------------------------------------


def test_a_second_pen_collection_in_a_report_does_not_end_the_first_pens_stroke() -> None:
    """Both were contact 0: the idle second collection ended the first pen's stroke in
    every report. The kernel maps one pen per report; so does stiction."""
    desc = parse_descriptor(pen(collection(0x20, pen_body()) + collection(0x20, pen_body())))
    stream = ReportStream(desc, "Acme Pen")
    first = struct.pack("<BHH", 0b11, 5000, 3000)  # tip + in range, mid-surface
    second = struct.pack("<BHH", 0, 9000, 100)  # nothing in range
    samples = [s for i in range(3) for s in stream.feed(float(i), bytes([2]) + first + second)]
    assert [(s.contact, s.in_range, s.tip) for s in samples] == [(0, True, True)] * 3
    assert samples[0].x == pytest.approx(0.127)


def _fingers(n: int, contact_id: bool) -> bytes:
    one = flags(0x42, 0x47)
    if contact_id:
        one += field(0x0D, 0x51, 0, 255, 8)
    one += field(1, 0x30, 0, 4000, 16, phi=400, unit=CM, exp=-1)
    one += field(1, 0x31, 0, 3000, 16, phi=300, unit=CM, exp=-1)
    body = item(RID, 3) + b"".join(collection(0x22, one, kind=2) for _ in range(n))
    return collection(0x04, body, kind=1)  # Touch Screen


@pytest.mark.parametrize("with_id", [False, True])
def test_two_fingers_in_one_report_are_two_contacts_with_or_without_identifiers(
    with_id: bool,
) -> None:
    desc = parse_descriptor(_fingers(2, contact_id=with_id))
    cid = (lambda i: bytes([4 + i])) if with_id else (lambda i: b"")
    fingers = [bytes([0b11]) + cid(i) + struct.pack("<HH", 1000 * (i + 1), 500) for i in range(2)]
    data = bytes([3]) + b"".join(fingers)
    got = ReportStream(desc, "Acme TS").feed(0.0, data)
    # the readable statement of a report agrees with the generated feed
    (mapping,) = build_mappings(desc, "Acme TS").values()
    ref = ContactTracker().samples(0.0, mapping, mapping.decoder.decode(data))
    assert got == ref
    assert [s.contact for s in got] == ([5, 6] if with_id else [1, 2])
    assert [round(s.x, 6) for s in got] == [0.1, 0.2]


# -- tilt -----------------------------------------------------------------------------


def _tilt_field(lo: int, hi: int, plo: int, phi: int, unit: int, exp: int) -> bytes:
    return field(0x0D, 0x3D, lo, hi, 16, plo=plo, phi=phi, unit=unit, exp=exp) + field(
        0x0D, 0x3E, lo, hi, 16, plo=plo, phi=phi, unit=unit, exp=exp
    )


@pytest.mark.parametrize(
    ("tilt", "raw", "degrees"),
    [
        ((-9000, 9000, -9000, 9000, DEGREES, -2), 4500, 45.0),  # most built-in pens
        # the Surface Book 2's pen: logical 0..18000 over -90..90 degrees, upright at 9000
        ((0, 18000, -9000, 9000, DEGREES, -2), 9000, 0.0),
        ((0, 18000, -9000, 9000, DEGREES, -2), 18000, 90.0),
        ((-60, 60, 0, 0, 0, 0), 30, 30.0),  # no unit: taken as degrees
        # -1..1 declared as -180..180 radians: 10,313 degrees per unit, read as degrees
        ((-1, 1, -180, 180, RADIANS, 0), 1, 1.0),
        # firmware garbage beyond the declared range: clamped to its end
        ((-9000, 9000, -9000, 9000, DEGREES, -2), 30000, 90.0),
        ((-9000, 9000, -9000, 9000, DEGREES, -2), -30000, -90.0),
        ((0, 18000, -9000, 9000, DEGREES, -2), 20000, 90.0),
        ((-60, 60, 0, 0, 0, 0), 3000, 60.0),  # no unit: degrees, the range's end
        # no unit and a range wider than a pen can lean: at most 90 degrees
        ((-127, 127, 0, 0, 0, 0), 120, 90.0),
        ((-127, 127, 0, 0, 0, 0), -127, -90.0),
    ],
)
def test_tilt_is_read_from_its_physical_range_and_clamped_where_a_pen_can_lean(
    tilt: tuple[int, int, int, int, int, int], raw: int, degrees: float
) -> None:
    desc = parse_descriptor(pen(collection(0x20, pen_body(tilt=_tilt_field(*tilt)))))
    data = bytes([2]) + struct.pack("<BHHhh", 0b11, 100, 100, raw, raw)
    (s,) = ReportStream(desc, "Acme Pen").feed(0.0, data)
    assert s.tilt_x == pytest.approx(degrees) and s.tilt_y == pytest.approx(degrees)
    (mapping,) = build_mappings(desc, "Acme Pen").values()
    # the readable statement of a report clamps alike
    assert ContactTracker().samples(0.0, mapping, mapping.decoder.decode(data)) == [s]


def test_the_surface_book_2_pen_is_upright_at_its_logical_middle(hid_data: Path) -> None:
    path = hid_data.parent / "coverage" / "microsoft-surface-book-2-045e0021-1.hid"
    rec = load_recording(path)
    tilts = [
        f
        for rep in parse_descriptor(rec.descriptor).input_reports.values()
        for f in rep.fields
        if f.usage == 0x000D003D
    ]
    assert tilts and all(tilt_map(f) == pytest.approx((0.01, -90.0)) for f in tilts)


# -- the live backend: what `stiction devices` lists and opening says ----------------


@pytest.mark.umockdev
def test_live_narrow_field_tablet_is_listed_with_its_problem_and_two_fingers_read(
    tmp_path: Path,
) -> None:
    exe = shutil.which("umockdev-run")
    if exe is None:
        pytest.fail("umockdev-run is not installed (Debian package umockdev)")
    narrow = pen(collection(0x20, pen_body(x_bits=8)))
    desc = parse_descriptor(_fingers(2, contact_id=False))
    report = bytes([3]) + b"".join(
        bytes([0b11]) + struct.pack("<HH", 1000 * (i + 1), 500) for i in range(2)
    )
    reports = [report, report, bytes([3]) + bytes(desc.input_reports[3].byte_size - 1)]
    runs = []
    for num, (name, raw, sent) in enumerate(
        [("Acme Pen", narrow, []), ("Acme TS", _fingers(2, contact_id=False), reports)], 5
    ):
        (tmp_path / name).mkdir()
        files = write_mock(tmp_path / name, name, 0x1234, num, raw, sent, num=num)
        node = files.dev_node
        cmd = [exe, "--device", str(files.device), "--ioctl", f"{node}={files.ioctl}",
               "--script", f"{node}={files.script}", "--",
               sys.executable, str(HELPER), node, str(len(sent)), "--discover"]  # fmt: skip
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        runs.append([json.loads(x) for x in proc.stdout.splitlines() if x.startswith("{")])
    pen_lines, ts_lines = runs
    (info,) = [x["discover"] for x in pen_lines if "discover" in x]
    assert "X field is 8 bits wide" in info["problem"]
    assert "X field is 8 bits wide" in next(x["open_error"] for x in pen_lines if "open_error" in x)
    got = [(x["contact"], x["in_range"], round(x["x"], 6)) for x in ts_lines if "x" in x]
    # the lift report's zeroed positions are passed on (the simulator holds a
    # contact where it last touched: sim/step.py `take`)
    assert got == [(1, True, 0.1), (2, True, 0.2)] * 2 + [(1, False, 0.0), (2, False, 0.0)]
