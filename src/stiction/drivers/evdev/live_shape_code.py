"""The shape functions' source (live_shapes.py): a pen's and a multi-touch device's.

A generated reader (live_code.py for pens, live_mt_code.py for multi-touch)
walks a read event by event. For a read of a known *shape* -- the (type,
code) of its events -- everything but the values is known in advance, so
the function written here for the shape does the loop's work in straight
lines: the values taken out of the unpacked tuple at once, the ranges tested
in one expression, the cells stored, the frame counted and its samples built
with the reader's own arithmetic (live_pen_sample.py for a pen,
live_mt_code._sample_code for multi-touch). It uses the reader's variables
as its own free variables (`cells()` in the reader's source), so
live_shapes.Shapes binds it to each reader's closure.

What a shape function does not cover returns None here (never compiled);
what it finds out only from the values (a slot out of range, contacts to be
made anew) returns `miss` before anything changed, and the reader's loop
takes the read. tests/evdev/test_evdev_live.py holds the readers equal to
the assembler read by read and breaks these functions on purpose.
"""

from __future__ import annotations

import textwrap

from evdev import ecodes

from stiction.drivers.evdev import live_mt_code
from stiction.drivers.evdev.frames import FrameAssembler
from stiction.drivers.evdev.live_pen_sample import derived_fields, sample_code
from stiction.drivers.evdev.live_shapes import SYN_REPORT_KEY, range_lines
from stiction.drivers.evdev.units import SurfaceUnits


def _pen_sample(units: SurfaceUnits, asm: FrameAssembler, changed: set[int]) -> str:
    """A shape function's sample (indent 0), returned: sample_code's numbers, with a
    field of an axis the read did not change taken from the last one made from the
    same value (`r<code>` the axis value, `f<code>` the field: each a float made
    once, not per read). The cache is checked against the value itself, so cells
    changed by the reader's loop or the assembler meanwhile only miss it."""
    derived = derived_fields(units, asm)
    lines = ["s = blank()", "s.t = sec + usec / 1_000_000"]
    positions = [code for code, attr, _ in derived if attr in ("x", "y")]
    if len(positions) < 2 or all(code in changed for code in positions):
        # the position moved (the usual read): sample_code's, `inside` and all
        full = sample_code(units, asm, "", "sec + usec / 1_000_000", ())
        lines += [
            line for line in full.splitlines()[2:] if line.startswith(("if inside", " ", "else"))
        ]
        derived = [d for d in derived if d[1] not in ("x", "y")]
    for code, attr, compute in derived:
        if code in changed:
            lines += [*compute, f"s.{attr} = v"]
        else:
            lines += [
                f"if c{code} == r{code}:",
                f"    s.{attr} = f{code}",
                "else:",
                *(f"    {line}" for line in compute),
                f"    s.{attr} = f{code} = v",
                f"    r{code} = c{code}",
            ]
    fields = {attr for _, attr, _ in derived_fields(units, asm)}
    full = sample_code(units, asm, "", "sec + usec / 1_000_000", ())
    for line in full.splitlines():
        # the fields no axis alone decides: tip, tool, buttons, constants, Nones
        if line.startswith("s.") and line.split(" = ")[0][2:] not in {"t", *fields}:
            if line.split(" = ")[0][2:] in ("x", "y"):
                continue
            lines.append(line)
    lines += ["last_sample = s", "s.__class__ = pen", "return s"]
    return "".join(f"{line}\n" for line in lines)


def _take_or_miss(targets: list[str], misses: list[str]) -> list[str]:
    """A shape function's first lines: the read's values out of `tup`, then `miss`
    (nothing changed yet) if any of the `misses` conditions holds."""
    return [
        f"{', '.join([*targets, 'sec', 'usec', 'last'])} = tup",
        "if (",
        *(f"    {m} or" for m in misses[:-1]),
        f"    {misses[-1]}",
        "):",
        "    return miss",
    ]


def pen_body(asm: FrameAssembler, units: SurfaceUnits, shape: list[tuple[int, int]]) -> str | None:
    """A pen's shape function (live_shapes.py): the read `shape` and a final SYN_REPORT.

    The same as the reader's loop over those events, written out: every value
    tested against its range at once (one out of range is counted, as the loop
    counts it), the cells assigned, the frame counted and its sample built and
    returned (None: no contact). Keys, other SYN events and unknown axes are
    not covered (None)."""
    ranges = asm._ranges
    x0, x1, y0, y1 = units._bounds
    surface = {ecodes.ABS_X: (x0, x1), ecodes.ABS_Y: (y0, y1)}
    targets: list[str] = []
    misses = [f"last != {SYN_REPORT_KEY}"]
    assign: list[str] = []
    checks: list[tuple[str, int, int, bool]] = []
    has_position = False
    for i, (ev_type, code) in enumerate(shape):
        if ev_type in (0, 1) or (ev_type == 3 and code not in ranges):
            return None  # SYN, keys, an unknown axis: the loop's
        if ev_type != 3:
            targets += ["_", "_"]  # EV_MSC and other types: no contact state
            continue
        lo, hi = ranges[code]
        targets += ["_", f"v{i}"]
        checks.append((f"v{i}", lo, hi, code in surface))
        assign.append(f"c{code} = v{i}")
        if code in surface:
            has_position = True
            if surface[code] != (lo, hi):
                s_lo, s_hi = surface[code]
                assign += [f"if v{i} < {s_lo!r} or v{i} > {s_hi!r}:", "    inside = False"]
    if not asm._has_tool_keys and not has_position:
        misses.append("not seen")  # the contact may end: the loop's
    lines = [
        *_take_or_miss(targets, misses),
        *range_lines(checks),
        *assign,
    ]
    if has_position:
        lines.append("seen = True")
    lines.append("asm._frames += 1")
    if asm._has_tool_keys:
        lines += ["if last_tool is None:", "    return None  # no contact"]
    else:
        lines.append("last_tool = default_tool")
    body = "".join(f"{line}\n" for line in lines)
    changed = {code for ev_type, code in shape if ev_type == 3}
    return body + _pen_sample(units, asm, changed)


def mt_body(asm: FrameAssembler, units: SurfaceUnits, shape: list[tuple[int, int]]) -> str | None:
    """A multi-touch shape function (live_shapes.py): the read `shape` and a final
    SYN_REPORT, when no contact begins or ends in it.

    The reader's loop over those events, written out (_branches' rules): every
    slot number tested against the slots (one off: `miss`, nothing changed, the
    loop takes the read), every kept value and checked axis against its range
    at once (one off is counted, as the loop counts it), then the values
    stored in order, the current slot left where the read leaves it, and each
    contact's sample made as at SYN_REPORT. A frame whose contacts must be
    made anew (a key or a tracking id came before it: `rebuild`,
    `keys_changed`) is the loop's (`miss`); tracking ids, keys, other SYN
    events, unknown axes and what the assembler takes (distance, tool type)
    are not covered (None)."""
    ranges = asm._ranges
    x0, x1, y0, y1 = units._bounds
    surface = {ecodes.ABS_MT_POSITION_X: (x0, x1), ecodes.ABS_MT_POSITION_Y: (y0, y1)}
    targets: list[str] = []
    misses = [f"last != {SYN_REPORT_KEY}", "rebuild", "keys_changed"]
    stores: list[str] = []
    checks: list[tuple[str, int, int, bool]] = []
    base = "base"  # the current slot's offset in vals: from `cur` until a slot event
    slot = None  # the variable holding the last slot event's value
    for i, (ev_type, code) in enumerate(shape):
        if ev_type in (0, 1) or (ev_type == 3 and code not in ranges):
            return None  # SYN, keys, an unknown axis: the loop's
        if ev_type != 3 or (code < live_mt_code.ABS_MT_SLOT):
            targets += ["_", "_"]  # EV_MSC, other types, legacy axes: nothing kept
            continue
        if code == live_mt_code.ABS_MT_TRACKING_ID or code in live_mt_code._HANDED_OVER:
            return None  # contacts may begin, end or change: the loop's
        v = f"v{i}"
        targets += ["_", v]
        if code == live_mt_code.ABS_MT_SLOT:
            misses.append(f"{v} < 0 or {v} >= {asm.num_slots}")
            slot = v
            base = f"b{i}"
            stores.append(f"{base} = 3 * {v}")
            continue
        lo, hi = ranges[code]
        kept = live_mt_code._KEPT
        checks.append((v, lo, hi, code in surface and surface[code] == (lo, hi) and code in kept))
        if code in kept:
            if base == "base" and "base = 3 * cur" not in stores:
                stores.insert(0, "base = 3 * cur")
            offset = f" + {live_mt_code._KEPT[code]}" if live_mt_code._KEPT[code] else ""
            stores.append(f"vals[{base}{offset}] = {v}")
            if code in surface and surface[code] != (lo, hi):
                s_lo, s_hi = surface[code]
                stores += [f"if {v} < {s_lo!r} or {v} > {s_hi!r}:", "    inside = False"]
    if slot is not None:
        stores.append(f"cur = {slot}")
    each = live_mt_code._sample_code(
        asm, units, "t", " " * 24 + "s.__class__ = pen\n" + " " * 24 + "out.append(s)\n"
    )
    # one finger (the usual read): its sample alone, no list and no loop
    _, _, body = each.partition("\n")  # the loop header off
    one = textwrap.dedent(body).replace("out.append(s)\n", "")
    samples = (
        "if len(active) == 1:\n"
        "    ((b, cid, tool, tip, btn, k),) = active\n"
        + textwrap.indent(one, "    ")
        + "    return s\n"
        + "out = []\n"
        + textwrap.dedent(each)
    )
    lines = [
        *_take_or_miss(targets, misses),
        *range_lines(checks),
        *stores,
        "asm._frames += 1",
        "t = sec + usec / 1_000_000",
    ]
    return "".join(f"{line}\n" for line in lines) + samples + "return out\n"
