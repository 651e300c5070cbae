"""The live reader's source for a multi-touch device (protocol B slots).

live_code.py writes a reader per device; this module writes the one for
touchpads and touchscreens. The common touchpad read is one frame in which
the fingers already down move: ABS_MT_SLOT, ABS_MT_POSITION_X/Y, maybe
ABS_MT_PRESSURE or ABS_MT_TOUCH_MAJOR, the legacy single-touch axes (which
the assembler ignores on a multi-touch device), EV_MSC, SYN_REPORT; and
every frame gives one sample per finger down. So the reader keeps:

- `vals`, a flat list of each slot's x, y and pressure (slot i at 3*i), its
  own copy of the assembler's slots, written in place by the events;
- `active`, one entry per contact of the last frame (slot, id, tool, tip,
  buttons, in slot order as the assembler lists them): what does not change
  while only positions and pressures do;
- `tids`, each slot's tracking id, and `cur`, the current slot.

Keys (the assembler's own key set; the buttons are worked out again at
SYN_REPORT) and tracking ids (FrameAssembler._set_slot_value's rules,
reused and replaced ids counted) are taken here too: the contacts are then
made anew in slot order at SYN_REPORT, and a contact that ended repeats
its last sample tip-up and out of range (`lasts`). What changes a
contact's tip or tool -- ABS_MT_DISTANCE, ABS_MT_TOOL_TYPE -- a slot out of
range, SYN_DROPPED and a read ending mid-frame go to the assembler, as in
live_code.py: the reader puts back the state it had when the read began
(`snap`), hands it to the assembler (`store`) and lets it take the whole
read. The samples are units._sample_function's, operation for operation:
tilt is None for a slot's contact, the pressure None while a slot has
never reported one. A read of a shape seen before is taken by a function
written for it (live_shape_code.mt_body, live_shapes.py) when no contact
begins or ends in it.
"""

from __future__ import annotations

import struct
from typing import Any

from evdev import ecodes

from stiction.drivers.blank_sample import BlankSample
from stiction.drivers.evdev.frames import INPUT_EVENT, FrameAssembler
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import PenSample

ABS_MT_SLOT = ecodes.ABS_MT_SLOT
#: slot codes that change a contact's tip or tool: the assembler's
_HANDED_OVER = (ecodes.ABS_MT_DISTANCE, ecodes.ABS_MT_TOOL_TYPE)
ABS_MT_TRACKING_ID = ecodes.ABS_MT_TRACKING_ID
MT_TOOL_PEN = 1
MT_TOOL_PALM = 2
#: the slot values the reader keeps, at these offsets in `vals`
_KEPT = {ecodes.ABS_MT_POSITION_X: 0, ecodes.ABS_MT_POSITION_Y: 1, ecodes.ABS_MT_PRESSURE: 2}
#: the order of the axis tests: the most frequent first
_ORDER = (
    ecodes.ABS_MT_POSITION_X,
    ecodes.ABS_MT_POSITION_Y,
    ecodes.ABS_X,
    ecodes.ABS_Y,
    ABS_MT_SLOT,
    ecodes.ABS_MT_PRESSURE,
)


COLLECT = (
    "if first is None:",
    "    first = s",
    "elif rest is None:",
    "    rest = [s]",
    "else:",
    "    rest.append(s)",
)
"""Both generated readers' lines that add sample `s` to the read's samples: the
first one alone, the rest in a list made only for a second (most reads have one),
all handed out once the whole read went well."""


def collect(indent: str) -> str:
    """COLLECT as source at `indent`."""
    return "".join(f"{indent}{line}\n" for line in COLLECT)


READ_START = """\
    data = b""
    fresh = None  # an unknown shape: None, ask to learn it; False once no more can be
    try:
        for data in reads:
            u = unpackers(len(data))
            if u is not None and ok:  # the shape path (live_shapes.py)
                tup = u(data)
                fn = known(tup[:-3:2], fresh)
                if fn is None:
                    fn = learn(tup[:-3:2])
                    if fn is None:
                        fresh = False
                if fn:
                    out = fn(tup)
                    if out is not miss:
                        shaped += 1
{took}
                        continue
            if not ok or len(data) >= long_read:
                store()
                out = fallback(data)
                load()
                made_samples += len(out)
                yield from out
                continue
"""
"""Both generated readers' first lines per read: a read whose shape has a function
(live_shapes.py; only reads shorter than the compiled loop's have an unpacker)
is taken by it while the reader holds the state, unless the function finds
the read is not one it covers (`miss`); `took` hands out what the function
returned. A read the reader does not take (it holds no state, or the read is
long enough for the compiled loop) goes whole to the assembler, with the state
stored into it and loaded back after."""

TOOK_ONE = """\
                        if out is not None:
                            made_samples += 1
                            yield out"""
"""A pen's shape function returns its read's sample, or None for a frame without one."""
TOOK_MANY = """\
                        if out.__class__ is pen:
                            made_samples += 1
                            yield out
                        else:
                            made_samples += len(out)
                            yield from out"""
"""A multi-touch shape function returns its read's sample (one finger) or samples
(a list, one per finger: none, or two and more)."""


HAND_OVER = """\
            store()
            out = fallback(data)
            load()
            made_samples += len(out)
            yield from out
    except gone:
        store()
        out = end(data)
        made_samples += len(out)
        yield from out
        raise
"""
"""Both generated readers' last lines: a read the reader does not take goes to
the assembler with the state stored into it and loaded back after, and a
device that goes away ends its contacts before DeviceGone is raised on."""


KEY_EVENT_AND_READ_END = f"""\
                if ev_type == 1:  # EV_KEY (FrameAssembler.feed_many_general's rules)
                    if code not in valid_keys:
                        odd = (*(odd or ()), 'unknown_code')
                    elif value == 0 or value == 1 or value == 2:
                        if ksnap is None:
                            ksnap = set(keys)
                        if value:
                            keys.add(code)
                        else:
                            keys.discard(code)
                        keys_changed = True
                    else:
                        odd = (*(odd or ()), 'bad_key_value')
                    continue
                # EV_MSC and other types: no contact state
            else:
                if ev_type == 0:  # the read ends with a SYN_REPORT: no frame left open
                    asm._frames += made
                    if odd is not None:
                        for name in odd:
                            stats[name] += 1
                    if first is not None:
                        if made == 1:  # the usual read: one frame, whose SYN_REPORT ends it
                            sec, usec = stamp(data, {-INPUT_EVENT.size})
                            t = sec + usec / 1_000_000
                            first.t = t
                            first.__class__ = pen
                            made_samples += 1
                            yield first
                            if rest is not None:
                                for s in rest:
                                    s.t = t
                                    s.__class__ = pen
                                made_samples += len(rest)
                                yield from rest
                        else:
                            out = stamped(data, first, rest)
                            made_samples += len(out)
                            yield from out
                    continue"""
"""The generated readers' shared tail of the event loop (pens and multi-touch
alike): a key event kept as FrameAssembler.feed_many_general keeps it, and a
read that ends on its SYN_REPORT counted and its samples handed out.

The event loop unpacks only type, code and value (`unpack`, TYPE_CODE_VALUE):
an event's time is needed only at a SYN_REPORT, and unpacking it for every
event made two int objects each time. So a sample is made in the loop with
`t` holding its frame's number in the read (1, 2, ...) and stays a
Filling; here, once the read went well, it gets its frame's time and
becomes a PenSample. The usual read is one frame, and its SYN_REPORT is the
read's last event (`stamp` reads that event's time); a read of several
frames goes through `stamped`."""


Filling = BlankSample
"""A PenSample while a generated reader fills it in (blank_sample.py). No Filling
outlives the read that made it: the reader changes the class of every sample it
hands out (KEY_EVENT_AND_READ_END, `stamped`)."""


TYPE_CODE_VALUE = struct.Struct(f"@{INPUT_EVENT.size - 8}xHHi")
"""`struct input_event` without its time: (type, code, value), as INPUT_EVENT
unpacks them (the time is two native longs at the start)."""
TIME = struct.Struct("@ll")
"""The time at the start of a `struct input_event`: (seconds, microseconds)."""


def stamped(data: bytes, first: Filling, rest: list[Filling] | None) -> list[PenSample]:
    """The samples of a read of several whole frames, each given its frame's time.

    Each sample's `t` holds its frame's number in the read, counted from 1
    (KEY_EVENT_AND_READ_END); the frame's time is that of its SYN_REPORT,
    the read's n-th SYN event (any other SYN code sends a read to the
    assembler, so a read that gets here has no other)."""
    times = [
        sec + usec / 1_000_000
        for sec, usec, ev_type, _, _ in INPUT_EVENT.iter_unpack(data)
        if ev_type == 0
    ]
    out: list[Any] = [first] if rest is None else [first, *rest]
    for s in out:
        s.t = times[s.t - 1]
        s.__class__ = PenSample
    return out


def minus(expr: str, offset: float) -> str:
    """`(expr - offset)`, or `expr` for a zero offset: the same number either way
    for the int values of an axis (an int minus 0.0 is that int as a float, as
    the multiplication or division after it would make it anyway)."""
    return expr if offset == 0 else f"({expr} - {offset!r})"


_READ_START_MANY = READ_START.format(took=TOOK_MANY)


def _branches(asm: FrameAssembler, units: SurfaceUnits) -> str:
    ranges = asm._ranges
    x0, x1, y0, y1 = units._bounds
    surface = {ecodes.ABS_MT_POSITION_X: (x0, x1), ecodes.ABS_MT_POSITION_Y: (y0, y1)}
    codes = sorted(ranges, key=lambda c: (_ORDER.index(c) if c in _ORDER else 99, c))
    out: list[str] = []
    for c in codes:
        lo, hi = ranges[c]
        check = f"                        if value < {lo} or value > {hi}:\n"
        check += "                            odd = (*(odd or ()), 'value_out_of_range')\n"
        if c < ABS_MT_SLOT and c not in _ORDER:
            continue  # the rarer legacy axes: tested together, below
        if c < ABS_MT_SLOT:
            body = "                        pass  # a legacy single-touch axis: ignored\n"
        elif c == ABS_MT_SLOT:
            body = (
                f"                        if value < 0 or value >= {asm.num_slots}:\n"
                "                            break  # slot_out_of_range: the assembler's\n"
                "                        cur = value\n"
                "                        base = 3 * value\n"
            )
        elif c == ABS_MT_TRACKING_ID:
            # FrameAssembler._set_slot_value's rules; the contacts are rebuilt at SYN_REPORT
            body = (
                "                        if tsnap is None:\n"
                "                            tsnap = tids[:]\n"
                "                        rebuild = True\n"
                "                        if value < 0:\n"
                "                            tids[cur] = -1\n"
                "                        elif value != tids[cur]:\n"
                "                            if value in tids:  # held by another slot\n"
                "                                odd = (*(odd or ()), 'tracking_id_reused')\n"
                "                                tids[cur] = -1\n"
                "                            else:\n"
                "                                if tids[cur] >= 0:\n"
                "                                    odd = (*(odd or ()), 'tracking_id_replaced')\n"
                "                                tids[cur] = value\n"
            )
        elif c in _HANDED_OVER:
            body = "                        break  # contacts may change: the assembler's\n"
        elif c in _KEPT:
            offset = f" + {_KEPT[c]}" if _KEPT[c] else ""
            body = f"                        vals[base{offset}] = value\n" + check
            if c in surface and surface[c] == (lo, hi):
                # the surface is the axis's range: one test serves both
                body += "                            inside = False\n"
            elif c in surface:
                s_lo, s_hi = surface[c]
                body += f"                        if value < {s_lo!r} or value > {s_hi!r}:\n"
                body += "                            inside = False\n"
        else:
            body = check  # ABS_MT_TOUCH_MAJOR and the like: checked, not kept
        out.append(f"                    {'if' if not out else 'elif'} code == {c}:\n{body}")
    legacy = sorted(c for c in codes if c < ABS_MT_SLOT and c not in _ORDER)
    if legacy:
        out.append(
            f"                    elif code < {ABS_MT_SLOT}:\n"
            f"                        if code not in {set(legacy)!r}:\n"
            "                            odd = (*(odd or ()), 'unknown_code')\n"
        )
    out.append(
        "                    else:\n                        odd = (*(odd or ()), 'unknown_code')\n"
    )
    return "".join(out)


def _sample_code(
    asm: FrameAssembler,
    units: SurfaceUnits,
    stamp: str = "made  # its frame's time once the read went well",
    hand: str = collect(" " * 24),
) -> str:
    """The statements (indented for the reader's loop) that make each contact's sample
    at SYN_REPORT; `stamp` is its time (or frame number), `hand` hands it on."""
    x0, x1, y0, y1 = units._bounds
    rx, ry = units._rx, units._ry
    ps = units._pressure
    if asm._has_mt_pressure and ps is not None:
        pressure = (
            "                        p = vals[b + 2]\n"
            "                        if p is None:\n"
            "                            s.pressure = None\n"
            "                        else:\n"
            f"                            pf = {minus('p', ps.offset)} * {ps.scale!r}\n"
            "                            s.pressure = "
            "0.0 if pf < 0.0 else 1.0 if pf > 1.0 else pf\n"
        )
    else:
        pressure = "                        s.pressure = None\n"
    return f"""                    for b, cid, tool, tip, btn, k in active:
                        s = blank()
                        s.t = {stamp}
                        if inside:  # on the surface, nothing to clamp (the common case)
                            s.x = {minus("vals[b]", x0)} / {rx!r} / 1000
                            s.y = {minus("vals[b + 1]", y0)} / {ry!r} / 1000
                        else:
                            xs = vals[b]
                            if xs < {x0!r}:
                                xs = {x0!r}
                            elif xs > {x1!r}:
                                xs = {x1!r}
                            ys = vals[b + 1]
                            if ys < {y0!r}:
                                ys = {y0!r}
                            elif ys > {y1!r}:
                                ys = {y1!r}
                            s.x = {minus("xs", x0)} / {rx!r} / 1000
                            s.y = {minus("ys", y0)} / {ry!r} / 1000
                        s.tip = tip
                        s.in_range = True
                        s.contact = cid
{pressure}                        s.tool = tool
                        s.tilt_x = None
                        s.tilt_y = None
                        s.buttons = btn
{hand}                        lasts[k] = s
"""


def source(asm: FrameAssembler, units: SurfaceUnits) -> str:
    """The multi-touch reader's source for this device (read it to see what runs)."""
    n = asm.num_slots
    has_p = asm._has_mt_pressure
    x0, x1, y0, y1 = units._bounds
    inside = (
        f"all({x0!r} <= vals[e[0]] <= {x1!r} and {y0!r} <= vals[e[0] + 1] <= {y1!r} "
        "for e in active)"
    )
    return f"""slots = asm._slots
stats = asm._counts
keys = asm._keys  # the assembler's own key set, changed in place
valid_keys = asm._valid_keys
ok = False  # the reader holds the state; else the assembler holds it
vals = [0] * {3 * n}  # x, y, pressure of slot i at 3 * i
tids = [-1] * {n}  # the tracking id of each slot
cur = 0
#: (3 * slot, id, tool, tip, buttons, k) per contact of the last frame, in slot order;
#: lasts[k] is the contact's last sample (the one an ended contact repeats)
active = ()
lasts = []
buttons = 0
rebuild = False  # the contacts are made anew at the next SYN_REPORT (_tid_changed)
keys_changed = False
made_samples = 0
shaped = 0  # reads taken by a shape function (live_shapes.py)
inside = False  # every contact's position is on the surface (False: the samples clamp)


def load():
    \"\"\"Take the state from the assembler, if it stands at a frame boundary.\"\"\"
    nonlocal ok, cur, active, lasts, buttons, rebuild, keys_changed, inside
    if (
        asm._n_pending
        or asm._dropping
        or asm._undo_abs
        or asm._undo_slots
        or asm._dirty
        or asm._keys_ok is not None
        or asm.needs_resync
        or not asm._slot_ok
    ):
        ok = False
        return
    for i, s in enumerate(slots):
        vals[3 * i] = s.x
        vals[3 * i + 1] = s.y
        vals[3 * i + 2] = s.pressure
        tids[i] = s.tid
    cur = asm._slot
    last = asm._last
    active = tuple((3 * c.slot, c.id, c.tool, c.tip, c.buttons, k) for k, c in enumerate(last))
    lasts = [sample(c, 0.0) for c in last]
    buttons = asm._button_state
    rebuild = asm._dirty_all or asm._tid_changed
    keys_changed = asm._keys_changed
    inside = {inside}
    ok = True


def store():
    \"\"\"Hand the assembler the state as of the last frame; the assembler holds it now.\"\"\"
    nonlocal ok
    if not ok:
        return
    ok = False
    for i, s in enumerate(slots):
        s.x = vals[3 * i]
        s.y = vals[3 * i + 1]
        s.pressure = vals[3 * i + 2]
        s.tid = tids[i]
    asm._slot = cur
    asm._slot_ok = True
    asm._slot_start = (cur, True)
    asm._button_state = buttons
    asm._dirty_all = asm._tid_changed = rebuild
    asm._keys_changed = keys_changed
    asm._last = tuple(
        tnew(
            Contact,
            (
                cid, b // 3, cid, tool, vals[b], vals[b + 1],
                {"vals[b + 2]" if has_p else "None"}, tip, True, None, None, btn,
            ),
        )
        for b, cid, tool, tip, btn, k in active
    )


def count():
    return made_samples


def count_shaped():
    return shaped


def cells():
    \"\"\"Names every variable a shape function may use (live_shapes.cells_of).\"\"\"
    return ({", ".join(cells(asm))})


def samples(reads):
    nonlocal cur, active, lasts, buttons, rebuild, keys_changed, made_samples, inside
    nonlocal shaped
{_READ_START_MANY}            snap = (vals[:], cur, active, buttons, rebuild, keys_changed, inside)
            tsnap = None  # tids, kept once a tracking id comes
            ksnap = None  # the key set, kept once a key comes
            base = 3 * cur
            ev_type = 0  # an empty read is a whole one
            odd = None  # the read's anomalies, counted once the read went well
            made = 0
            first = None  # the read's samples, yielded once the whole read went well
            rest = None
            for ev_type, code, value in unpack(data):
                if ev_type == 3:  # EV_ABS
{_branches(asm, units)}                    continue
                if ev_type == 0:
                    if code != 0:  # SYN_DROPPED, SYN_CONFIG, SYN_MT_REPORT: the assembler's
                        break
                    # SYN_REPORT: FrameAssembler._commit's rules for a multi-touch frame
                    made += 1
                    if keys_changed:
                        keys_changed = False
                        b = key_buttons()
                        if b != buttons:
                            buttons = b
                            rebuild = True  # every contact carries the buttons
                    if rebuild:
                        # contacts may begin or end: made anew, in slot order
                        rebuild = False
                        made_now = []
                        for i, sl in enumerate(slots):
                            tid = tids[i]
                            if tid >= 0:
                                tt = sl.tool_type
                                if tt != {MT_TOOL_PALM}:
                                    made_now.append(
                                        (
                                            3 * i, tid, pen_tool if tt == {MT_TOOL_PEN} else finger,
                                            sl.distance == 0, buttons, len(made_now),
                                        )
                                    )
                        ids = [e[1] for e in made_now]
                        for e in active:
                            if e[1] not in ids:  # ended: its last sample, tip up, out of range
                                o = lasts[e[5]]
                                s = blank()
                                s.t = made  # its frame's time once the read went well
                                s.x = o.x
                                s.y = o.y
                                s.tip = False
                                s.in_range = False
                                s.contact = o.contact
                                s.pressure = o.pressure
                                s.tool = o.tool
                                s.tilt_x = None
                                s.tilt_y = None
                                s.buttons = o.buttons
{collect(" " * 32)}                        active = tuple(made_now)
                        lasts = [None] * len(made_now)
                        inside = {inside}
{_sample_code(asm, units)}                    continue
{KEY_EVENT_AND_READ_END}
            # the read needs the assembler (or ends mid-frame): it takes the whole read,
            # from the state as it began
            vals[:], cur, active, buttons, rebuild, keys_changed, inside = snap
            if tsnap is not None:
                tids[:] = tsnap
            if ksnap is not None:
                keys.clear()
                keys.update(ksnap)
{HAND_OVER}"""


def cells(asm: FrameAssembler) -> list[str]:
    """The reader's variables a multi-touch shape function uses (its free variables)."""
    return [
        "vals",
        "cur",
        "active",
        "lasts",
        "inside",
        "asm",
        "stats",
        "rebuild",
        "keys_changed",
    ]
