"""Decoded report values -> PenSamples in surface metres.

Works from the descriptor alone: any report that carries absolute X and Y in
a digitizer application (pen, touch screen, touchpad) is a contact report,
and each Stylus/Puck/Finger collection in it is one contact. The rest of a
device's reports (vendor data, mouse emulation, keyboards) are counted and
ignored. Where the descriptor has no physical size, the caller passes one
(from the device table or the user); with neither, the device is refused,
because coordinates that are not metres would silently break the physics.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import dataclass, replace

from stiction.drivers.hid.decoder import ReportDecoder
from stiction.drivers.hid.descriptor import CONTACT_COLLECTIONS, Field, Report, ReportDescriptor
from stiction.drivers.hid.units import MAX_TILT_DEG, extent_m, raw_extent_m, tilt_map, unit_name
from stiction.drivers.sample import PenSample, Tool
from stiction.errors import DeviceError, SizeUnknown

log = logging.getLogger(__name__)

GD_X, GD_Y = 0x00010030, 0x00010031
DIG = 0x000D0000
DIG_DIGITIZER, DIG_PEN, DIG_TOUCHSCREEN, DIG_TOUCHPAD = (
    DIG | 0x01,
    DIG | 0x02,
    DIG | 0x04,
    DIG | 0x05,
)
DIG_STYLUS, DIG_PUCK, DIG_FINGER = DIG | 0x20, DIG | 0x21, DIG | 0x22
TIP_PRESSURE, IN_RANGE, INVERT, X_TILT, Y_TILT = (
    DIG | 0x30,
    DIG | 0x32,
    DIG | 0x3C,
    DIG | 0x3D,
    DIG | 0x3E,
)
TIP_SWITCH, BARREL, ERASER = DIG | 0x42, DIG | 0x44, DIG | 0x45
CONFIDENCE, CONTACT_ID, CONTACT_COUNT, SECONDARY_BARREL = (
    DIG | 0x47,
    DIG | 0x51,
    DIG | 0x54,
    DIG | 0x5A,
)

_WANTED = (
    GD_X,
    GD_Y,
    TIP_PRESSURE,
    IN_RANGE,
    INVERT,
    X_TILT,
    Y_TILT,
    TIP_SWITCH,
    BARREL,
    ERASER,
    CONFIDENCE,
    CONTACT_ID,
    SECONDARY_BARREL,
)

WACOM_VENDOR_PAGE = 0xFF0D

APPLICATION_KIND = {
    DIG_DIGITIZER: "pen",
    DIG_PEN: "pen",
    DIG_STYLUS: "pen",
    (WACOM_VENDOR_PAGE << 16) | 0x01: "pen",
    (WACOM_VENDOR_PAGE << 16) | 0x02: "pen",
    DIG_TOUCHSCREEN: "touchscreen",
    DIG_TOUCHPAD: "touchpad",
}


@dataclass(frozen=True, slots=True)
class Axis:
    """How one coordinate element maps to metres."""

    element: int
    logical_min: int
    metres_per_unit: float


@dataclass(frozen=True, slots=True)
class ContactLayout:
    """Where one contact's values sit in the decoded tuple of its report."""

    finger: bool
    x: Axis
    y: Axis
    width_m: float
    height_m: float
    el: dict[int, int]  # usage -> element index (first occurrence in the group)
    pressure_min: int
    pressure_span: int
    tilt_x_deg: float
    tilt_y_deg: float
    #: degrees at logical 0 (tilt = value * deg + off): non-zero where the field's
    #: physical range is not centred on its logical 0 (units.tilt_map)
    tilt_x_off: float = 0.0
    tilt_y_off: float = 0.0
    #: the degrees a tilt is clamped to: its logical range's ends, at most 90
    #: degrees from upright (a report's garbage is not a pen leaning 3000 degrees)
    tilt_x_range: tuple[float, float] = (-MAX_TILT_DEG, MAX_TILT_DEG)
    tilt_y_range: tuple[float, float] = (-MAX_TILT_DEG, MAX_TILT_DEG)
    #: a finger without a Contact Identifier: its place among the report's such
    #: fingers, so that two of them are two contacts (1 + ordinal), not one
    ordinal: int = 0


@dataclass(frozen=True, slots=True)
class ReportMapping:
    decoder: ReportDecoder
    contacts: tuple[ContactLayout, ...]
    contact_count: int | None  # element index of Contact Count


def canonical_usage(usage: int, aliases: dict[int, int] | None = None) -> int:
    """The standard usage a field stands for.

    Wacom's vendor page 0xff0d repeats the digitizer page with X and Y at
    0x130/0x131 (the kernel's wacom_equivalent_usage does the same); the
    device table may alias further usages (a button that is the tip).
    """
    if aliases and usage in aliases:
        return aliases[usage]
    if usage >> 16 == WACOM_VENDOR_PAGE:
        low = usage & 0xFFFF
        if low == 0x130:
            return GD_X
        if low == 0x131:
            return GD_Y
        return DIG | low
    return usage


def _first_fields(
    fields: list[Field], decoder: ReportDecoder, aliases: dict[int, int] | None
) -> dict[int, dict[int, int]]:
    """group -> usage -> element index of the first non-constant variable field with that usage."""
    index_of_field = {e.field_index: i for i, e in reversed(list(enumerate(decoder.elements)))}
    groups: dict[int, dict[int, int]] = {}
    for fi, f in enumerate(fields):
        if f.constant or not f.variable or fi not in index_of_field:
            continue
        usage = canonical_usage(f.usage, aliases)
        if usage in (GD_X, GD_Y) and f.relative:
            continue
        g = groups.setdefault(f.group, {})
        if usage in _WANTED and usage not in g:
            g[usage] = index_of_field[fi]
    return groups


def bits_needed(f: Field) -> int:
    """The bits a field needs to carry its logical range: unsigned when the minimum
    is not negative (as the kernel and hid-tools read it), else two's complement."""
    if f.logical_min >= 0:
        return max(f.logical_max, 0).bit_length()
    return max(f.logical_max.bit_length(), (-f.logical_min - 1).bit_length()) + 1


def _position_defect(device: str, rid: int, fx: Field, fy: Field) -> DeviceError | None:
    """A position field that cannot be a surface axis, as the error that says so.

    An empty logical range divides by zero; a field narrower than its range
    (a 4-bit X declared 0..10000, a 0-bit one) can never reach most of the
    surface, so every position would land in a corner of it: a wrong surface
    no warning would show. Neither is a size the user could give.
    """
    if fx.logical_max <= fx.logical_min or fy.logical_max <= fy.logical_min:
        return DeviceError(
            f"{device}: report {rid} has an empty logical range for X or Y "
            f"(X {fx.logical_min}..{fx.logical_max}, Y {fy.logical_min}..{fy.logical_max})"
        )
    for name, f in (("X", fx), ("Y", fy)):
        need = bits_needed(f)
        if f.bit_size < need:
            return DeviceError(
                f"{device}: report {rid}'s {name} field is {f.bit_size} bits wide but "
                f"declares logical {f.logical_min}..{f.logical_max}, which needs {need}: "
                'the descriptor is wrong; give a corrected one (descriptor = "<hex>" in '
                "its entry of ~/.config/stiction/hid-devices.toml, docs/devices.md)"
            )
    return None


def _axis_size(f: Field, override: float | None) -> float | None:
    if override is not None:
        return override
    return extent_m(f)


def _size_error(device: str, f: Field, which: str) -> SizeUnknown:
    claimed = raw_extent_m(f)
    what = "no physical size"
    if math.isfinite(claimed) and claimed > 0:
        what = f"a physical size no surface has ({claimed:.6g} m)"
    return SizeUnknown(
        f"{device}: the report descriptor gives {what} for {which} "
        f"(unit {unit_name(f.unit)}, physical {f.physical_min}..{f.physical_max}), so its "
        "coordinates cannot be converted to metres",
        "size_mm = [width, height] in its entry of ~/.config/stiction/hid-devices.toml "
        "(docs/devices.md)",
    )


def build_mappings(
    desc: ReportDescriptor,
    device: str,
    size_m: tuple[float, float] | None = None,
    pen_reports: frozenset[int] = frozenset(),
    aliases: dict[int, int] | None = None,
) -> dict[int, ReportMapping]:
    """Contact mappings for every input report that carries contacts, keyed by report ID.

    A report counts when its application collection is a digitizer (or
    Wacom's vendor digitizer), or when the device table lists it in
    `pen_reports`. Raises DeviceError when a contact report has no physical
    size and none is given, or a position field that cannot be an axis
    (`_position_defect`), unless the node has a readable report of another kind.
    """
    mappings: dict[int, ReportMapping] = {}
    unsized: list[tuple[str | None, DeviceError]] = []  # (kind, why) of reports left out
    pointer_pens = not _has_digitizer(desc)
    for rid, report in desc.input_reports.items():
        page = report.application >> 16
        if (
            page not in (DIG >> 16, WACOM_VENDOR_PAGE)
            and rid not in pen_reports
            and not (pointer_pens and _pen_in_pointer(report))
        ):
            continue
        skip = False
        decoder = ReportDecoder(report)
        groups = _first_fields(report.fields, decoder, aliases)
        group_usage = {
            f.group: (f.logical if f.logical in CONTACT_COLLECTIONS else f.physical)
            for f in report.fields
        }
        contacts: list[ContactLayout] = []
        for gid, el in groups.items():
            if GD_X not in el or GD_Y not in el:
                continue
            fx = report.fields[decoder.elements[el[GD_X]].field_index]
            fy = report.fields[decoder.elements[el[GD_Y]].field_index]
            defect = _position_defect(device, rid, fx, fy)
            if defect is not None:  # left out like a report without a size (below)
                unsized.append((report_kind(report, pointer_pens), defect))
                skip = True
                break
            w = _axis_size(fx, size_m[0] if size_m else None)
            h = _axis_size(fy, size_m[1] if size_m else None)
            if w is None or h is None:
                why = _size_error(device, fx, "X") if w is None else _size_error(device, fy, "Y")
                unsized.append((report_kind(report, pointer_pens), why))
                skip = True
                break
            finger = group_usage.get(gid) == DIG_FINGER or (
                APPLICATION_KIND.get(report.application) in ("touchpad", "touchscreen")
                and group_usage.get(gid) not in (DIG_STYLUS, DIG_PUCK)
            )
            if not finger and any(not c.finger for c in contacts):
                # A second pen in one report is contact 0 again, and its idle
                # collection would end the first pen's stroke at every report.
                # The kernel maps one pen per report too (hid-input gives the
                # second X no ABS_X); count on the first.
                log.info("%s: report %d has more than one pen collection: the first "
                         "is read", device, rid)  # fmt: skip
                continue
            pmin, pspan = 0, 0
            if TIP_PRESSURE in el:
                fp = report.fields[decoder.elements[el[TIP_PRESSURE]].field_index]
                pmin, pspan = fp.logical_min, fp.logical_max - fp.logical_min
            tx, tx0, ty, ty0 = 1.0, 0.0, 1.0, 0.0
            txr = tyr = (-MAX_TILT_DEG, MAX_TILT_DEG)
            if X_TILT in el:
                ftx = report.fields[decoder.elements[el[X_TILT]].field_index]
                tx, tx0 = tilt_map(ftx)
                txr = _tilt_range(ftx, tx, tx0)
            if Y_TILT in el:
                fty = report.fields[decoder.elements[el[Y_TILT]].field_index]
                ty, ty0 = tilt_map(fty)
                tyr = _tilt_range(fty, ty, ty0)
            contacts.append(
                ContactLayout(
                    finger=finger,
                    x=Axis(el[GD_X], fx.logical_min, w / (fx.logical_max - fx.logical_min)),
                    y=Axis(el[GD_Y], fy.logical_min, h / (fy.logical_max - fy.logical_min)),
                    width_m=w,
                    height_m=h,
                    el=el,
                    pressure_min=pmin,
                    pressure_span=pspan,
                    tilt_x_deg=tx,
                    tilt_y_deg=ty,
                    tilt_x_off=tx0,
                    tilt_y_off=ty0,
                    tilt_x_range=txr,
                    tilt_y_range=tyr,
                    ordinal=sum(1 for c in contacts if c.finger and CONTACT_ID not in c.el),
                )
            )
        if skip or not contacts:
            continue
        count_el = next(
            (
                i
                for i, e in enumerate(decoder.elements)
                if canonical_usage(e.usage, aliases) == CONTACT_COUNT
                and report.fields[e.field_index].variable
            ),
            None,
        )
        mappings[rid] = ReportMapping(decoder, tuple(contacts), count_el)
    # A report without a size, or with a position field that cannot be an axis,
    # is left out only beside reports of another kind that are readable: the
    # kernel makes one input device per kind, and libinput drops a tablet
    # without resolution while the node's touch screen works (Huion Kamvas 13's
    # touch interface also declares the firmware pen in in^3).
    kept = {report_kind(desc.input_reports[rid], pointer_pens) for rid in mappings}
    for kind, refusal in unsized:
        if not kept or kind in kept:
            raise refusal
    return mappings if size_m else _one_panel(mappings)


def _xy_fields(m: ReportMapping, c: ContactLayout) -> tuple[Field, Field]:
    fields = m.decoder.report.fields
    return (
        fields[m.decoder.elements[c.x.element].field_index],
        fields[m.decoder.elements[c.y.element].field_index],
    )


def _numbers(f: Field) -> tuple[int, int, int, int]:
    return f.logical_min, f.logical_max, f.physical_min, f.physical_max


def _one_panel(mappings: dict[int, ReportMapping]) -> dict[int, ReportMapping]:
    """A pen that repeats its touch screen's numbers in another unit takes the touch screen's size.

    Built-in touch screens with a pen on one HID node (Goodix's USI-pen
    firmware: 27c6:0e00 in hid-tools' tests, 27c6:0e51 in the Lenovo
    Chromebook Duet 5) give the pen report the very logical and physical
    numbers of the finger report, but in thousandths of an inch where the
    fingers have tenths of a millimetre: read as written, the pen of a
    13.3-inch screen covers 75 x 42 mm (and the kernel and libinput say so).
    Identical numbers over the same glass cannot be two sizes; the finger
    reading is the one that agrees with the screen (293.7 x 165.2 mm is a
    13.3-inch 16:9 panel), so the pen takes it.
    """
    fingers = [(_xy_fields(m, c), c) for m in mappings.values() for c in m.contacts if c.finger]
    if not fingers:
        return mappings
    out: dict[int, ReportMapping] = {}
    for rid, m in mappings.items():
        contacts = []
        for c in m.contacts:
            if not c.finger:
                px, py = _xy_fields(m, c)
                twin = next(
                    (
                        fc
                        for (fx, fy), fc in fingers
                        if _numbers(fx) == _numbers(px)
                        and _numbers(fy) == _numbers(py)
                        and (fx.unit, fx.unit_exponent) != (px.unit, px.unit_exponent)
                    ),
                    None,
                )
                if twin is not None:
                    c = replace(
                        c,
                        x=replace(c.x, metres_per_unit=twin.x.metres_per_unit),
                        y=replace(c.y, metres_per_unit=twin.y.metres_per_unit),
                        width_m=twin.width_m,
                        height_m=twin.height_m,
                    )
            contacts.append(c)
        out[rid] = replace(m, contacts=tuple(contacts))
    return out


GD_POINTER, GD_MOUSE = 0x00010001, 0x00010002


def _pen_in_pointer(report: Report) -> bool:
    """A pen reported as a Mouse (or Pointer): absolute X and Y beside a Tip Pressure.

    XP-Pen and UGEE firmware ("UGTABLET", the Deco 03's report 9) put the pen
    in a Mouse application collection: absolute X/Y and Tip Pressure, the
    tip on button 1. No mouse has a pressure axis and absolute coordinates
    (virtual machines' absolute pointers have none); tablets that also have
    a digitizer report are read from that one (see _has_digitizer).
    """
    if report.application not in (GD_POINTER, GD_MOUSE):
        return False
    absolute = {f.usage for f in report.fields if f.variable and not f.constant and not f.relative}
    return {GD_X, GD_Y, TIP_PRESSURE} <= absolute


def _has_digitizer(desc: ReportDescriptor) -> bool:
    """Whether any input report sits in a digitizer (or Wacom digitizer) application.

    Only where none does is a pen looked for in Mouse collections: Huion and
    UC-Logic tablets also send a Mouse report with absolute X/Y and pressure
    in their default mode, beside the pen report that counts.
    """
    return any(
        r.application >> 16 in (DIG >> 16, WACOM_VENDOR_PAGE) for r in desc.input_reports.values()
    )


def report_kind(report: Report, pointer_pens: bool = False) -> str | None:
    """ "pen", "touchscreen" or "touchpad" for a report that can carry contacts, else None.

    `pointer_pens`: the descriptor has no digitizer report, so a Mouse
    report with absolute X/Y and pressure is the pen (see _pen_in_pointer).
    """
    kind = APPLICATION_KIND.get(report.application)
    if kind is None and pointer_pens and _pen_in_pointer(report):
        return "pen"
    return kind


def _has_length(report: Report) -> bool:
    """Whether the report's X axis has a physical length (a size of its own), and
    no position field of it is one `_position_defect` refuses."""
    xy = [
        f
        for f in report.fields
        if canonical_usage(f.usage) in (GD_X, GD_Y) and f.variable and not f.constant
    ]
    if any(f.logical_max <= f.logical_min or f.bit_size < bits_needed(f) for f in xy):
        return False
    return any(canonical_usage(f.usage) == GD_X and extent_m(f) is not None for f in xy)


def device_kind(desc: ReportDescriptor, pen_reports: frozenset[int] = frozenset()) -> str:
    """ "pen", "touchscreen", "touchpad" or "other", from the input reports' applications.

    Where some contact kinds have a size in the descriptor and others not,
    the node is of a kind that has one (see build_mappings: the others are
    left out, as libinput leaves out a tablet without resolution).
    """
    reports = list(desc.input_reports.values())
    pointer_pens = not _has_digitizer(desc)
    kinds = {report_kind(r, pointer_pens) for r in reports}
    sized = {report_kind(r, pointer_pens) for r in reports if _has_length(r)} - {None}
    if sized and not pen_reports:
        kinds = sized
    if pen_reports & set(desc.input_reports):
        kinds.add("pen")
    for k in ("pen", "touchscreen", "touchpad"):
        if k in kinds:
            return k
    return "other"


def _tilt_range(f: Field, deg: float, off: float) -> tuple[float, float]:
    """The degrees a tilt field's values are clamped to: its logical range's ends
    (the sum the samples make), within 90 degrees of upright."""
    ends = sorted((f.logical_min * deg + off, f.logical_max * deg + off))
    return max(ends[0], -MAX_TILT_DEG), min(ends[1], MAX_TILT_DEG)


def _tilt(
    v: tuple[int, ...], i: int | None, deg: float, off: float, bounds: tuple[float, float]
) -> float | None:
    """Degrees of a tilt value, clamped to `bounds`; the offset added only where
    there is one, as the generated code does (adding 0.0 would turn -0.0 into 0.0)."""
    if i is None:
        return None
    tv = v[i] * deg + off if off != 0.0 else v[i] * deg
    lo, hi = bounds
    return lo if tv < lo else hi if tv > hi else tv


class ContactTracker:
    """Turns decoded values into PenSamples, remembering which contacts are active.

    The last sample of a contact (lift, out of range) is emitted once with
    `in_range=False`; idle reports with nothing in range produce nothing.
    Multi-touch reports in hybrid mode (Contact Count in the first report of
    a frame, 0 in the ones that follow) are followed across reports.
    """

    def __init__(self, stats: Counter[str] | None = None) -> None:
        self.active: dict[int, bool] = {}
        self.last: dict[int, PenSample] = {}
        self.remaining = 0
        self.stats: Counter[str] = stats if stats is not None else Counter()

    def samples(self, t: float, m: ReportMapping, values: tuple[int, ...]) -> list[PenSample]:
        out: list[PenSample] = []
        layouts = m.contacts
        if m.contact_count is not None and any(c.finger for c in layouts):
            n = values[m.contact_count]
            if n > 0:
                self.remaining = n
            take = min(len(layouts), max(self.remaining, 0))
            self.remaining -= take
            layouts = layouts[:take]
        for c in layouts:
            s = self._sample(t, c, values)
            if s is not None:
                out.append(s)
        return out

    def _sample(self, t: float, c: ContactLayout, v: tuple[int, ...]) -> PenSample | None:
        el = c.el
        tip_i = el.get(TIP_SWITCH)
        eraser_i = el.get(ERASER)
        invert_i = el.get(INVERT)
        pressure: float | None = None
        if TIP_PRESSURE in el and c.pressure_span > 0:
            pressure = min(max((v[el[TIP_PRESSURE]] - c.pressure_min) / c.pressure_span, 0.0), 1.0)
        inverted = bool(invert_i is not None and v[invert_i])
        # Eraser is the tip switch of the pen's eraser end, which the pen
        # signals with Invert (Microsoft's pen protocol); where the descriptor
        # has Invert, an Eraser bit without it is not a touch (UC-Logic
        # firmware descriptors put Eraser on the second barrel button's bit).
        eraser = bool(eraser_i is not None and v[eraser_i]) and (inverted or invert_i is None)
        if tip_i is not None:
            tip = bool(v[tip_i]) or eraser
        else:
            tip = pressure is not None and pressure > 0.0
        if c.finger:
            contact = 1 + (v[el[CONTACT_ID]] if CONTACT_ID in el else c.ordinal)
            confident = CONFIDENCE not in el or bool(v[el[CONFIDENCE]])
            in_range = tip and confident
            tip = in_range
            tool = Tool.FINGER
        else:
            contact = 0
            in_range = bool(v[el[IN_RANGE]]) if IN_RANGE in el else True
            in_range = in_range or tip
            tool = Tool.ERASER if (eraser or inverted) else Tool.PEN
        was = self.active.get(contact, False)
        if not in_range and not was:
            return None
        self.active[contact] = in_range
        x = (v[c.x.element] - c.x.logical_min) * c.x.metres_per_unit
        y = (v[c.y.element] - c.y.logical_min) * c.y.metres_per_unit
        if not (0.0 <= x <= c.width_m and 0.0 <= y <= c.height_m):
            # Outside the declared logical range: garbage from the device, kept
            # on the surface so a glitch cannot throw the pen metres away.
            self.stats["clamped_positions"] += 1
            x = min(max(x, 0.0), c.width_m)
            y = min(max(y, 0.0), c.height_m)
        buttons = 0
        if BARREL in el and v[el[BARREL]]:
            buttons |= 1
        if SECONDARY_BARREL in el and v[el[SECONDARY_BARREL]]:
            buttons |= 2
        sample = PenSample(
            t=t,
            x=x,
            y=y,
            tip=tip and in_range,
            in_range=in_range,
            contact=contact,
            pressure=pressure,
            tool=tool,
            tilt_x=_tilt(v, el.get(X_TILT), c.tilt_x_deg, c.tilt_x_off, c.tilt_x_range),
            tilt_y=_tilt(v, el.get(Y_TILT), c.tilt_y_deg, c.tilt_y_off, c.tilt_y_range),
            buttons=buttons,
        )
        self.last[contact] = sample
        return sample

    def leave_all(self, t: float) -> list[PenSample]:
        """End every active contact at its last position (the tool stopped reporting)."""
        out = []
        for contact, active in self.active.items():
            last = self.last.get(contact)
            if active and last is not None:
                out.append(replace(last, t=t, tip=False, in_range=False, pressure=None))
                self.active[contact] = False
        return out
