"""A feed loop written for one single-tool device (a pen tablet without slots).

FrameAssembler.feed_many_general keeps every axis in a dict and looks up the
axis's range, its undo entry and the frame flags for each event; a pen frame
is four or five events and one contact, so those lookups are most of its
cost. Here, as hid/report_code.py does for HID report layouts, the loop is
written out as Python source for the device at hand: each axis the device
has is a local variable (`a<code>`, with `c<code>` its value at the last
SYN_REPORT), each range check compares against literal numbers, and the
SYN_REPORT builds the Contact straight from the locals.

Anything but an axis, EV_MSC or SYN_REPORT (keys, SYN_DROPPED and the
dropped stretch after it, other SYN codes, unknown types) is handed to
feed_many_general one event at a time: the locals are first written into the
assembler's own state the way the general loop would have left it (current
values in `_abs`, the last frame's values of changed axes in `_undo_abs`),
and read back after. tests/evdev/test_evdev_fast_paths.py holds this loop
equal to feed_many_general on every recording and on random streams.
"""

from __future__ import annotations

import operator
import textwrap
from collections.abc import Callable, Iterable
from typing import Any

from evdev import ecodes

# frames.py imports this module, so nothing here imports frames.py: the
# assembler (`asm`) and the names the loop needs come in as arguments.
FrameAssembler = Any
Feed = Callable[[Iterable[tuple[int, int, int, int, int]]], list[Any]]

#: the order of the axis tests: the most frequent axes of the recordings first
_ORDER = (
    ecodes.ABS_X,
    ecodes.ABS_Y,
    ecodes.ABS_PRESSURE,
    ecodes.ABS_TILT_X,
    ecodes.ABS_TILT_Y,
    ecodes.ABS_DISTANCE,
)


def sorted_codes(asm: FrameAssembler) -> list[int]:
    """The device's axes in the order the loop tests them."""
    return sorted(asm._abs, key=lambda c: (_ORDER.index(c) if c in _ORDER else 99, c))


def source(asm: FrameAssembler) -> str:
    """The loop's source for this assembler's device (read it to see what runs)."""
    codes = sorted_codes(asm)
    ranges = asm._ranges
    has_x, has_y = ecodes.ABS_X in asm._abs, ecodes.ABS_Y in asm._abs
    p = ecodes.ABS_PRESSURE
    tx, ty = ecodes.ABS_TILT_X, ecodes.ABS_TILT_Y
    tool = "key_tool" if asm._has_tool_keys else "default_tool if seen else None"
    pressure = f"a{p}" if asm._has_pressure else "None"
    if asm._has_touch_key:
        tip = "key_touch"
    elif asm._has_pressure:
        tip = f"a{p} > {asm._pressure_min!r}"
    else:
        tip = "False"
    tilt_x = f"a{tx}" if asm._has_tilt else "None"
    tilt_y = f"a{ty}" if asm._has_tilt else "None"
    names = ", ".join(f"a{c}" for c in codes)
    if len(codes) > 1:
        load = f"    {names} = get_axes(abs_)\n"
    else:
        load = "".join(f"    a{c} = abs_[{c}]\n" for c in codes)
    load += "".join(f"    c{c} = a{c}\n" for c in codes)
    # the state when no frame is in progress: every axis at its committed value
    settled = "{" + ", ".join(f"{c}: a{c}" for c in codes) + "}"
    reload = "".join(
        f"        a{c} = abs_[{c}]\n        c{c} = undo.get({c}, a{c})\n" for c in codes
    )
    store = "".join(
        f"{{i}}abs_[{c}] = a{c}\n"
        f"{{i}}if a{c} != c{c} and {c} not in undo:\n"
        f"{{i}}    undo[{c}] = c{c}\n"
        for c in codes
    )
    commit = "".join(f"                c{c} = a{c}\n" for c in codes)
    branches = []
    for i, c in enumerate(codes):
        lo, hi = ranges[c]
        seen = "                    seen = True\n" if c in (ecodes.ABS_X, ecodes.ABS_Y) else ""
        branches.append(
            f"                {'if' if i == 0 else 'elif'} code == {c}:\n"
            f"                    a{c} = value\n"
            f"                    if value < {lo} or value > {hi}:\n"
            f"                        stats['value_out_of_range'] += 1\n"
            f"{seen}"
        )
    if branches:
        branches.append("                else:\n                    stats['unknown_code'] += 1\n")
        axis_code = "                code = ev[3]\n                value = ev[4]\n" + "".join(
            branches
        )
    else:
        axis_code = "                stats['unknown_code'] += 1\n"
    return f"""abs_ = asm._abs
undo = asm._undo_abs
stats = asm._counts
general = asm.feed_many_general


def feed(events):
    out = []
    append = out.append
    n = asm._n_pending
    seen = asm._seen_position
    seen_ok = asm._seen_start
    last = asm._last
    dropping = asm._dropping
    force = asm._dirty_all or asm._keys_ok is not None
    stale = asm._keys_changed  # key_tool, key_touch and buttons need _key_state()
    key_tool = asm._key_tool
    key_touch = asm._key_touch
    buttons = asm._button_state
    made = 0
    clear_resync = False
{load}    for ev in events:
        ev_type = ev[2]
        if not dropping:
            if ev_type == 3:  # EV_ABS
                n += 1
{axis_code}                continue
            if ev_type == 0 and ev[3] == 0:  # SYN_REPORT
                made += 1
                clear_resync = True
                if n or force:
                    if force or stale:
                        if force:
                            force = False
                            asm._dirty_all = False
                            asm._keys_ok = None
                        stale = False
                        if asm._keys_changed:
                            asm._key_state()
                        key_tool = asm._key_tool
                        key_touch = asm._key_touch
                        buttons = asm._button_state
                    tool = {tool}
                    if tool is None:
                        append(tnew(Frame, (ev[0], ev[1], (), (ended(last[0]),) if last else ())))
                        last = ()
                    else:
                        last = (
                            tnew(
                                Contact,
                                (
                                    0, None, None, tool,
                                    {f"a{ecodes.ABS_X}" if has_x else "0"},
                                    {f"a{ecodes.ABS_Y}" if has_y else "0"},
                                    {pressure}, {tip}, True, {tilt_x}, {tilt_y}, buttons,
                                ),
                            ),
                        )
                        append(tnew(Frame, (ev[0], ev[1], last, ())))
                else:
                    append(tnew(Frame, (ev[0], ev[1], last, ())))
                n = 0
                if undo:
                    undo.clear()
{commit}                seen_ok = seen
                continue
            if ev_type != 0 and ev_type != 1:  # EV_MSC and others: no contact state
                n += 1
                continue
        # to feed_many_general: the locals into the assembler's state, and back
{store.format(i="        ")}        asm._n_pending = n
        asm._seen_position = seen
        asm._seen_start = seen_ok
        asm._last = last
        if clear_resync:
            asm.needs_resync = False
            clear_resync = False
        out.extend(general((ev,)))
        n = asm._n_pending
        seen = asm._seen_position
        seen_ok = asm._seen_start
        last = asm._last
        dropping = asm._dropping
        force = asm._dirty_all or asm._keys_ok is not None
        stale = asm._keys_changed
        key_tool = asm._key_tool
        key_touch = asm._key_touch
        buttons = asm._button_state
{reload}    # the batch is over: the state as feed_many_general would leave it
    if n:
{store.format(i="        ")}    else:
        abs_.update({settled})
    asm._n_pending = n
    asm._seen_position = seen
    asm._seen_start = seen_ok
    asm._last = last
    if clear_resync:
        asm.needs_resync = False
    asm._frames += made
    return out
"""


_FACTORIES: dict[tuple[object, ...], Callable[[FrameAssembler], Feed]] = {}


def _key(asm: FrameAssembler) -> tuple[object, ...]:
    """Everything source() reads: assemblers that agree on it share one compiled loop."""
    return (
        tuple(sorted(asm._ranges.items())),
        asm._has_tool_keys,
        asm._has_pressure,
        asm._has_touch_key,
        asm._pressure_min,
        asm._has_tilt,
        asm._default_tool,
    )


def compile_feed(asm: FrameAssembler, names: dict[str, object]) -> Feed:
    """The generated loop, bound to `asm`; compiled once per kind of device.

    `names`: Frame, Contact and ended (frames._ended), from frames.py."""
    key = _key(asm)
    make = _FACTORIES.get(key)
    if make is None:
        namespace: dict[str, object] = {
            "tnew": tuple.__new__,
            "get_axes": operator.itemgetter(*sorted_codes(asm)),
            "default_tool": asm._default_tool,
            **names,
        }
        text = "def make(asm):\n" + textwrap.indent(source(asm), "    ") + "    return feed\n"
        code = compile(text, f"<evdev feed: {asm.desc.name}>", "exec")
        exec(code, namespace)
        make = namespace["make"]  # type: ignore[assignment]
        _FACTORIES[key] = make  # type: ignore[assignment]
    return make(asm)  # type: ignore[misc]
