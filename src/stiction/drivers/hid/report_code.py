"""A device's path from report bytes to PenSamples, generated once from its layout.

`ReportStream.feed` runs for every report a tablet sends (every 4-8 ms, and
millions of times in a replay). ContactTracker (pen.py) is the readable
statement of what a report means: per contact it looks up which values the
layout has, converts units, decides tip, range and tool, and builds a
PenSample by keyword. Each of those steps is a dictionary lookup or a call
that depends only on the layout, so most of its 6 us per report went on
questions whose answer never changes for a device.

Here they are asked once. `compile_feed` writes the device's whole feed as
one function: the counting, the fix-up, and per contact report ID a branch
with the layout's element indices and constants filled in, which decodes
only the values the contacts use (inline, no tuple of all of them) and
builds the samples without keyword arguments or the frozen dataclass's
per-field ``object.__setattr__`` (see stiction.drivers.blank_sample);
`compile_report` writes one report ID's path alone. Both do what
ContactTracker._sample does, operation for operation (the same float
expressions in the same order, so the same samples bit for bit:
tests/hid/test_hid_report_code.py runs them against ContactTracker over
every recording), and update the tracker's `active` and `last` the same
way. Layouts they do not cover -- finger reports with a Contact Count,
whose contacts follow across reports -- stay with ContactTracker.

A vendor report family (families.py) has its reports read by a Python
reader into a PenState that is then packed into a normalised report; for
those `compile_feed` calls the reader and sets the values the contacts read
from the PenState itself (`_family_lines`), so the same contact code runs
without the bytes in between.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from typing import Any, Protocol

from stiction.drivers.blank_sample import FIELDS, BlankSample
from stiction.drivers.hid.decoder import decode_statements
from stiction.drivers.hid.pen import (
    BARREL,
    CONFIDENCE,
    CONTACT_ID,
    ERASER,
    IN_RANGE,
    INVERT,
    SECONDARY_BARREL,
    TIP_PRESSURE,
    TIP_SWITCH,
    X_TILT,
    Y_TILT,
    ContactLayout,
    ReportMapping,
)
from stiction.drivers.sample import PenSample, Tool

ReportFn = Callable[[float, bytes], list[PenSample]]
"""(t, report bytes) -> the report's samples, tracker state and counters updated."""

_SLOTS = FIELDS


def covered(m: ReportMapping) -> bool:
    """Whether `compile_report` handles this mapping (else ContactTracker does)."""
    return not (m.contact_count is not None and any(c.finger for c in m.contacts))


def _namespace(active: dict[int, bool], last: dict[int, PenSample], stats: Counter[str]) -> Any:
    return {
        "PenSample": PenSample,
        "Blank": BlankSample,
        "active": active,
        "last": last,
        "stats": stats,
        "PEN": Tool.PEN,
        "ERASER": Tool.ERASER,
        "FINGER": Tool.FINGER,
    }


Returns = Callable[[str, str], list[str]]
"""(value, count) -> the statements that end the report with `value`, `count` samples."""


def _body(
    m: ReportMapping,
    ns: dict[str, Any],
    prefix: str,
    ret: Returns,
    values: dict[int, str] | None = None,
) -> list[str]:
    """The statements of one report's path (unindented), from the bytes ``d`` to a return.

    Constants go into `ns` under names starting with `prefix`. With
    `values` (usage -> an expression), each element the contacts read is
    that expression instead of its bits of ``d`` (a vendor family's values,
    see `compile_feed`); a usage it lacks raises KeyError.
    """
    # Only the elements some contact reads are decoded, in report order.
    used: list[int] = []
    for c in m.contacts:
        used.extend((c.x.element, c.y.element))
        for usage in (
            TIP_PRESSURE,
            TIP_SWITCH,
            ERASER,
            INVERT,
            IN_RANGE,
            CONTACT_ID,
            CONFIDENCE,
            BARREL,
            SECONDARY_BARREL,
            X_TILT,
            Y_TILT,
        ):
            if usage in c.el:
                used.append(c.el[usage])
    order = sorted(set(used), key=lambda i: (m.decoder.elements[i].bit_offset, i))
    name_of = {i: f"e{i}" for i in order}
    elements = [m.decoder.elements[i] for i in order]
    if values is None:
        lines = decode_statements(elements, [name_of[i] for i in order], ns)
    else:
        lines = [f"{name_of[i]} = {values[e.usage]}" for i, e in zip(order, elements, strict=True)]
    single = len(m.contacts) == 1  # the usual pen report: no list to append to
    if not single:
        lines.append("out = []")
    for k, c in enumerate(m.contacts):
        lines.extend(_contact_lines(f"{prefix}{k}_", c, name_of, ns, ret if single else None))
    lines.extend(ret("[]", "0") if single else ret("out", "len(out)"))
    return lines


def _indent(lines: list[str], depth: int) -> list[str]:
    return ["    " * depth + line for line in lines]


def compile_report(
    m: ReportMapping,
    active: dict[int, bool],
    last: dict[int, PenSample],
    stats: Counter[str],
) -> ReportFn | None:
    """The generated path for one report ID, or None where `covered` says no.

    `active`, `last` and `stats` are the ContactTracker's own dictionaries
    and counters, which the generated code reads and writes in place.
    """
    if not covered(m):
        return None
    ns = _namespace(active, last, stats)
    body = _body(m, ns, "c", lambda value, count: [f"return {value}"])
    source = "\n".join(["def report(t, d):", *_indent(body, 1)])
    exec(compile(source, f"<hid report {m.decoder.report_id} samples>", "exec"), ns)
    fn = ns["report"]
    fn.source = source  # for a reader wondering what runs
    return fn  # type: ignore[no-any-return]


class StreamHooks(Protocol):
    """What the generated feed reads and writes on its ReportStream."""

    _fed: int
    _made: int
    _sampled: bool
    _last_report_t: float | None

    def _bad(self, what: str, message: str) -> list[PenSample]: ...
    def _rest(self, t: float, data: bytes) -> list[PenSample]: ...


def compile_feed(
    stream: StreamHooks,
    mappings: dict[int, ReportMapping],
    numbered: bool,
    fixup: Callable[[bytes], bytes | None] | None,
    active: dict[int, bool],
    last: dict[int, PenSample],
    stats: Counter[str],
    ignored: frozenset[int] = frozenset(),
    timed: bool = True,
    family: FamilyValues | None = None,
) -> ReportFn:
    """ReportStream.feed for this device as one generated function.

    `ignored`: the input report IDs that carry no contact (counted as
    ignored). `timed`: the stream has a proximity timeout, so the time of
    the last report is kept. `family`: the fix-up is a vendor family's
    (families.FamilyFixup), whose one report the mappings describe; see
    `_family_lines`.

    Counting, the fix-up, the choice of report ID and every covered report
    ID's path are written out in one function (a report then costs one
    Python call); anything else -- an empty, unknown, short or uncovered
    report -- goes to `stream._rest`, the general path after counting and
    fix-up, so the two paths share one statement of what those mean.
    """
    ns = _namespace(active, last, stats)
    ns.update(st=stream, fixup=fixup, DecodeErrors=(ValueError, IndexError, OverflowError))

    def ret(value: str, count: str) -> list[str]:
        # A report that made samples says so through _made (ReportStream.stats).
        counting = ["st._sampled = True"] if count == "0" else [f"st._made += {count}"]
        if count not in ("0", "1"):
            counting.insert(0, "st._sampled = True")  # len(out) may be 0
        return [*counting, f"return {value}"]

    lines = ["def feed(t, d):", "    st._fed += 1"]
    if timed:  # only ReportStream.idle reads it, and only with a proximity timeout
        lines.append("    st._last_report_t = t")
    if family is not None:
        direct = _family_lines(mappings, numbered, family, ns, ret)
        if direct is not None:
            source = "\n".join([*lines, *_indent(direct, 1), "    return st._rest(t, d)"])
            exec(compile(source, "<hid report stream feed, vendor family>", "exec"), ns)
            fn = ns["feed"]
            fn.source = source
            return fn  # type: ignore[no-any-return]
    if fixup is not None:
        lines += [
            "    if d:",
            "        fixed = fixup(d)",
            "        if fixed is None:",
            '            stats["ignored"] += 1',
            "            return []",
            "        d = fixed",
        ]
    branches: list[str] = []
    for rid, m in mappings.items():
        if not covered(m):
            continue
        test = f"rid == {rid} and " if numbered else ""
        branches.append(
            f"{'if' if not branches else 'elif'} {test}len(d) >= {m.decoder.byte_size}:"
        )
        body = _body(m, ns, f"r{rid}_", ret)
        branches += _indent(["try:", *_indent(body, 1)], 1)
        branches += _indent(
            [
                "except DecodeErrors as exc:",
                f'    return st._bad("bad_values", f"report {rid} could not be decoded: {{exc}}")',
            ],
            1,
        )
    if numbered and ignored:
        # Input reports that carry no contact (vendor data, mouse emulation):
        # counted and dropped here, as _rest would.
        ns["IGNORED"] = frozenset(ignored)
        branches += [
            f"{'if' if not branches else 'elif'} rid in IGNORED:",
            '    stats["ignored"] += 1',
            "    return []",
        ]
    if branches:
        lines += ["    if d:"]
        if numbered:
            lines += ["        rid = d[0]"]
        lines += _indent(branches, 2)
    lines += ["    return st._rest(t, d)"]
    source = "\n".join(lines)
    exec(compile(source, "<hid report stream feed>", "exec"), ns)
    fn = ns["feed"]
    fn.source = source
    return fn  # type: ignore[no-any-return]


class FamilyValues(Protocol):
    """What the generated feed needs of a vendor family (families.FamilyFixup)."""

    @property
    def fields(self) -> tuple[str, ...]: ...
    @property
    def report_id(self) -> int: ...
    @property
    def read(self) -> Callable[[bytes], Any]: ...
    def values(self) -> dict[int, str]: ...


def _family_lines(
    mappings: dict[int, ReportMapping],
    numbered: bool,
    family: FamilyValues,
    ns: dict[str, Any],
    ret: Returns,
) -> list[str] | None:
    """The feed's statements after counting for a vendor family, None where they do not apply.

    The family's bytes path reads a report into a PenState, packs it into
    the normalised report and the branch of that report decodes the bytes
    again. Here the reader's PenState goes straight into that branch, its
    fields unpacked as ``pen_`` + name: each value the contacts read is the
    expression `family.values()` gives for its usage (what the packed bytes
    would decode to), so the pack and the decode disappear and the contact
    code is the same `_contact_lines` as every other report's. A report
    the reader refuses is counted as ignored, an empty one goes to `_rest`,
    as on the bytes path. None (the bytes path is kept) unless the mappings
    are the one covered report of a family's generated descriptor, with the
    family's report ID, and every usage its contacts read has an expression.
    """
    if not numbered or len(mappings) != 1:
        return None
    ((rid, m),) = mappings.items()
    if rid != family.report_id or not covered(m):
        return None
    ns["read"] = family.read
    try:
        body = _body(m, ns, f"r{rid}_", ret, family.values())
    except KeyError:
        return None
    return [
        "if d:",
        "    pen = read(d)",
        "    if pen is None:",
        '        stats["ignored"] += 1',
        "        return []",
        f"    ({', '.join('pen_' + f for f in family.fields)},) = pen",
        *_indent(body, 1),
    ]


def _contact_lines(
    prefix: str, c: ContactLayout, name_of: dict[int, str], ns: dict[str, Any], ret: Returns | None
) -> list[str]:
    """ContactTracker._sample for one contact, with the layout's answers written in.

    Unindented; `ret` ends the report with this contact's sample (a report
    with one contact), None appends it to ``out``.
    """
    el = c.el

    def v(usage: int) -> str:
        return name_of[el[usage]]

    def const(label: str, value: object) -> str:
        # A number is written as a literal (repr gives back the same float or
        # int, bit for bit): a constant then costs nothing to load.
        if type(value) is int or (type(value) is float and math.isfinite(value)):
            return f"({value!r})"
        key = f"{prefix}{label}"
        ns[key] = value
        return key

    out: list[str] = []
    add = out.append
    if TIP_PRESSURE in el and c.pressure_span > 0:
        pmin, pspan = const("pmin", c.pressure_min), const("pspan", c.pressure_span)
        # min(max(p, 0.0), 1.0) without the two calls: the same value for any
        # finite p (a quotient of integers is never NaN or -0.0).
        add(f"pressure = {_minus(v(TIP_PRESSURE), pmin)} / {pspan}")
        add("if pressure < 0.0:")
        add("    pressure = 0.0")
        add("elif pressure > 1.0:")
        add("    pressure = 1.0")
    else:
        add("pressure = None")
    invert = INVERT in el
    if invert:
        add(f"inverted = {v(INVERT)} != 0")
    if ERASER in el:
        guard = " and inverted" if invert else ""
        add(f"eraser = {v(ERASER)} != 0{guard}")
    else:
        add("eraser = False")
    if TIP_SWITCH in el:
        add(f"tip = {v(TIP_SWITCH)} != 0 or eraser")
    else:
        add("tip = pressure is not None and pressure > 0.0")
    if c.finger:
        add(f"contact = 1 + {v(CONTACT_ID)}" if CONTACT_ID in el else f"contact = {1 + c.ordinal}")
        if CONFIDENCE in el:
            add(f"in_range = tip and {v(CONFIDENCE)} != 0")
        else:
            add("in_range = tip")
        add("tip = in_range")
        add("tool = FINGER")
    else:
        add("contact = 0")
        if IN_RANGE in el:
            add(f"in_range = {v(IN_RANGE)} != 0 or tip")
        else:
            add("in_range = True")
        add(f"tool = ERASER if ({'eraser or inverted' if invert else 'eraser'}) else PEN")
    add("if in_range or active.get(contact, False):")
    add("    active[contact] = in_range")
    xmin, xmpu = const("xmin", c.x.logical_min), const("xmpu", c.x.metres_per_unit)
    ymin, ympu = const("ymin", c.y.logical_min), const("ympu", c.y.metres_per_unit)
    w, h = const("w", c.width_m), const("h", c.height_m)
    add(f"    x = {_minus(name_of[c.x.element], xmin)} * {xmpu}")
    add(f"    y = {_minus(name_of[c.y.element], ymin)} * {ympu}")
    add(f"    if not (0.0 <= x <= {w} and 0.0 <= y <= {h}):")
    add('        stats["clamped_positions"] += 1')
    add(f"        x = min(max(x, 0.0), {w})")
    add(f"        y = min(max(y, 0.0), {h})")
    bits = [f"(1 if {v(BARREL)} else 0)"] if BARREL in el else []
    bits += [f"(2 if {v(SECONDARY_BARREL)} else 0)"] if SECONDARY_BARREL in el else []

    def tilt(usage: int, label: str, deg: float, off: float, bounds: tuple[float, float]) -> str:
        if usage not in el:
            return "None"
        # the same sum and clamp as ContactTracker's; `+ 0.0` would turn -0.0 into 0.0
        shift = f" + {const(label + 'o', off)}" if off != 0.0 else ""
        lo, hi = const(label + "lo", bounds[0]), const(label + "hi", bounds[1])
        value = f"{v(usage)} * {const(label, deg)}{shift}"
        return f"({lo} if (tv := {value}) < {lo} else {hi} if tv > {hi} else tv)"

    tx = tilt(X_TILT, "txd", c.tilt_x_deg, c.tilt_x_off, c.tilt_x_range)
    ty = tilt(Y_TILT, "tyd", c.tilt_y_deg, c.tilt_y_off, c.tilt_y_range)
    values = {
        "t": "t",
        "x": "x",
        "y": "y",
        "tip": "tip",  # tip and in_range: a touch is always in range (pen or finger)
        "in_range": "in_range",
        "contact": "contact",
        "pressure": "pressure",
        "tool": "tool",
        "tilt_x": tx,
        "tilt_y": ty,
        "buttons": " | ".join(bits) or "0",
    }
    if set(values) != set(_SLOTS):  # pragma: no cover - PenSample grew a field
        raise RuntimeError(f"PenSample's fields changed: {_SLOTS}; update report_code.py")
    add("    s = Blank()")
    for field in _SLOTS:
        add(f"    s.{field} = {values[field]}")
    add("    s.__class__ = PenSample")
    add("    last[contact] = s")
    if ret is None:
        add("    out.append(s)")
    else:
        out.extend(_indent(ret("[s]", "1"), 1))
    return out


def _minus(value: str, minimum: str) -> str:
    """``(value - minimum)``; the integer itself when the minimum is a literal 0."""
    return value if minimum == "(0)" else f"({value} - {minimum})"
