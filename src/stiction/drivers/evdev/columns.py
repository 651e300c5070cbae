"""A large read() -> PenSamples with numpy: Python runs per sample, not per event.

The frame assembler (frames.py) runs Python for every event: five of them
for a pen frame, more for a touchpad. When one read() returns many frames
(a replay, or a reader that fell behind), the events can instead be decoded
in one go (`numpy.frombuffer` with `struct input_event`'s layout) and the
state at each SYN_REPORT found with array operations: every axis, slot
value and key is "the last value set at or before this frame's SYN_REPORT,
else the state the batch began with" -- one `searchsorted` for all of them
at once. Python then only builds the PenSamples, one per contact per frame.

This relies on one property of the assembler, held by its tests: a frame's
contacts are a function of the state at its SYN_REPORT (each rebuilt contact
is made from the state, and a reused one from a state that has not changed
since), and a contact that ended is the previous frame's contact with
tip=False, in_range=False. So the samples are those `frame_samples()` would
give for the assembler's frames, and the assembler is left exactly as
feed_many would leave it (tests/evdev/test_evdev_columns.py compares both on
every recording and on random streams).

Whatever is rare and stateful is left to the assembler: a batch holding
SYN_DROPPED, a slot number out of range, or a frame in progress at its start
returns None, and the caller takes the per-event path. Key events and
tracking-id changes are few (a handful per stroke), so they are replayed in
Python here, exactly as the assembler applies them.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from evdev import ecodes

from stiction.drivers.blank_sample import BlankSample
from stiction.drivers.evdev.frames import (
    _TOOL_ORDER,
    ABS_MT_DISTANCE,
    ABS_MT_POSITION_X,
    ABS_MT_POSITION_Y,
    ABS_MT_PRESSURE,
    ABS_MT_SLOT,
    ABS_MT_TOOL_TYPE,
    ABS_MT_TRACKING_ID,
    BUTTON_BITS,
    MT_TOOL_PALM,
    MT_TOOL_PEN,
    SYN_DROPPED,
    Contact,
    FrameAssembler,
    _tnew,
)
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import PenSample, Tool

#: struct input_event on a 64-bit Linux ABI: two longs (timeval), u16, u16, s32
EVENT = np.dtype(
    {
        "names": ["sec", "usec", "type", "code", "value"],
        "formats": ["=i8", "=i8", "=u2", "=u2", "=i4"],
        "offsets": [0, 8, 16, 18, 20],
        "itemsize": 24,
    }
)
#: the layout above is the native one (elsewhere, e.g. 32-bit: always the per-event path)
AVAILABLE = struct.calcsize("@llHHi") == EVENT.itemsize and struct.calcsize("@l") == 8

#: a read of fewer events goes the per-event way: numpy's fixed cost per call
#: (some 40 array operations) is more than the Python it saves on a few frames
MIN_EVENTS = 160

_TOOLS: tuple[Tool | None, ...] = (None, *Tool)
_TOOL_INDEX = {t: i for i, t in enumerate(_TOOLS)}
_ABS_SIZE = 0x40  # ABS_CNT: codes above are unknown to every device
_NONE = -(2**40)  # "never set" (a slot's pressure before its first ABS_MT_PRESSURE)
_MT_CODES = (
    ABS_MT_TRACKING_ID,
    ABS_MT_POSITION_X,
    ABS_MT_POSITION_Y,
    ABS_MT_PRESSURE,
    ABS_MT_DISTANCE,
    ABS_MT_TOOL_TYPE,
)
_X, _Y, _P, _TX, _TY = (
    ecodes.ABS_X,
    ecodes.ABS_Y,
    ecodes.ABS_PRESSURE,
    ecodes.ABS_TILT_X,
    ecodes.ABS_TILT_Y,
)
_BTN_TOUCH = ecodes.BTN_TOUCH


class _Plan:
    """Per-device tables: made once per kind of device (the device never changes)."""

    def __init__(self, asm: FrameAssembler) -> None:
        self.known = np.zeros(_ABS_SIZE + 1, bool)
        self.lo = np.zeros(_ABS_SIZE + 1, np.int64)
        self.hi = np.zeros(_ABS_SIZE + 1, np.int64)
        for code, (lo, hi) in asm._ranges.items():
            if code < _ABS_SIZE:
                self.known[code] = True
                self.lo[code], self.hi[code] = lo, hi
        if asm.multitouch:
            self.codes = [c for c in _MT_CODES if c in asm._ranges]
        else:
            # the axes a contact is made of first, then the rest (kept, never read)
            used = [c for c in (_X, _Y, _P, _TX, _TY) if c in asm._abs]
            self.codes = used + sorted(set(asm._abs) - set(used))
        #: how many of `codes` a frame's contact needs (per frame); the rest only
        #: matter for the state the batch leaves
        self.n_frame = len(used) if not asm.multitouch else len(self.codes)
        #: lookup key of a code (its rank in `codes`), -1 for codes not kept
        self.rank = np.full(_ABS_SIZE + 1, -1, np.int64)
        for i, c in enumerate(self.codes):
            self.rank[c] = i


_PLANS: dict[tuple[object, ...], _Plan] = {}


def _plan(asm: FrameAssembler) -> _Plan:
    key = (asm.multitouch, tuple(sorted(asm._ranges.items())), tuple(sorted(asm._abs)))
    plan = _PLANS.get(key)
    if plan is None:
        plan = _PLANS[key] = _Plan(asm)
    return plan


def _key_tool(keys: set[int] | frozenset[int]) -> int:
    for code, tool in _TOOL_ORDER:
        if code in keys:
            return _TOOL_INDEX[tool]
    return 0


def _key_buttons(keys: set[int] | frozenset[int]) -> int:
    b = 0
    for code, bit in BUTTON_BITS.items():
        if code in keys:
            b |= bit
    return b


def _keys(
    asm: FrameAssembler, ev: np.ndarray, reports: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, set[int], int, int]:
    """Per row (the batch's start, then each frame): tool index, BTN_TOUCH, buttons.

    Key events are replayed one by one as the assembler does (a set of keys
    down; codes the device lacks and values other than 0/1/2 counted and
    ignored). Also returns the final key set and the two counts."""
    keys = set(asm._keys)
    valid = asm._valid_keys
    at = [-1]
    tool = [_key_tool(keys)]
    touch = [_BTN_TOUCH in keys]
    buttons = [_key_buttons(keys)]
    unknown = bad = 0
    where = np.flatnonzero(ev["type"] == 1)
    if where.size:
        sel = ev[where]
        for i, code, value in zip(
            where.tolist(), sel["code"].tolist(), sel["value"].tolist(), strict=True
        ):
            if code not in valid:
                unknown += 1
                continue
            if value == 0:
                keys.discard(code)
            elif value == 1 or value == 2:
                keys.add(code)
            else:
                bad += 1
                continue
            at.append(i)
            tool.append(_key_tool(keys))
            touch.append(_BTN_TOUCH in keys)
            buttons.append(_key_buttons(keys))
    rows = np.concatenate(([-1], reports))
    pos = np.searchsorted(np.asarray(at[1:], np.int64), rows, side="right")
    return (
        np.asarray(tool)[pos],
        np.asarray(touch)[pos],
        np.asarray(buttons)[pos],
        keys,
        unknown,
        bad,
    )


class _Index:
    """The last value of each key at any event index: events sorted once, asked at will.

    A key is one quantity (an axis; a slot's axis); `at` (event indices) must
    increase. `get` answers every question with one searchsorted over
    (key, event index) composites: the last entry at or before the question's,
    if it has the same key, else `init[key]` (the state the batch began with)."""

    def __init__(
        self, key: np.ndarray, at: np.ndarray, value: np.ndarray, n_events: int, init: np.ndarray
    ) -> None:
        self.span = n_events + 1
        order = np.argsort(key, kind="stable")  # `at` stays increasing within a key
        self.comp = key[order] * self.span + at[order]
        self.vals = value[order]
        self.init = init

    def get(self, key: np.ndarray, at: np.ndarray) -> np.ndarray:
        """The value of `key` after event `at` (broadcast together; -1: before all)."""
        base = key * self.span
        q = base + at
        if self.comp.size == 0:
            return np.broadcast_to(self.init[key], q.shape)
        pos = np.searchsorted(self.comp, q, side="right") - 1
        np.maximum(pos, 0, out=pos)
        found = self.comp[pos]
        got: np.ndarray = np.where((found >= base) & (found <= q), self.vals[pos], self.init[key])
        return got


Retime = Callable[[np.ndarray], np.ndarray]


def samples(
    asm: FrameAssembler, units: SurfaceUnits, data: bytes, retime: Retime | None = None
) -> list[PenSample] | None:
    """The samples of every frame `data` (whole input_events) completes; None: not here.

    None means nothing was consumed and the caller feeds the events through
    the assembler instead (see the module doc for when). `retime`, if given,
    maps the times of all the frames (Frame.time, in order) to the times their
    samples get (a replay's pause compression); it sees every frame, those
    without contacts too."""
    if not AVAILABLE or asm._dropping or asm._n_pending or len(data) % EVENT.itemsize:
        return None
    ev = np.frombuffer(data, EVENT)
    typ = ev["type"]
    code = ev["code"]
    syn = typ == 0
    if np.any(syn & (code == SYN_DROPPED)):
        return None
    reports = np.flatnonzero(syn & (code == 0))
    if reports.size == 0:
        return None
    end = int(reports[-1]) + 1
    tail = ev[end:]
    ev = ev[:end]
    frame_t = _times(ev, reports)
    if asm.multitouch:
        made = _multitouch(asm, units, ev, reports, frame_t, retime)
    else:
        made = _single(asm, units, ev, reports, frame_t, retime)
    if made is None:
        return None
    if tail.size:
        fields = [tail[f].tolist() for f in ("sec", "usec", "type", "code", "value")]
        asm.feed_many_general(list(zip(*fields, strict=True)))
    return made


def _abs_events(
    plan: _Plan, ev: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """EV_ABS events: their indices, codes (ABS_CNT for unknown ones), values; known mask."""
    where = np.flatnonzero(ev["type"] == 3)
    sel = ev[where]
    c = np.minimum(sel["code"], _ABS_SIZE).astype(np.int64)
    v = sel["value"].astype(np.int64)
    known = plan.known[c]
    return where, c, v, known, int(where.size - np.count_nonzero(known))


def _finish(
    asm: FrameAssembler, frames: int, unknown: int, out_of_range: int, bad_keys: int
) -> None:
    counts = asm._counts
    if unknown:
        counts["unknown_code"] += unknown
    if out_of_range:
        counts["value_out_of_range"] += out_of_range
    if bad_keys:
        counts["bad_key_value"] += bad_keys
    asm._frames += frames
    asm.needs_resync = False
    asm._undo_abs.clear()
    asm._undo_slots.clear()
    asm._keys_ok = None
    asm._dirty.clear()
    asm._dirty_all = False
    asm._tid_changed = False
    asm._key_state()  # tool, touch and buttons of the final key set
    asm._slot_start = (asm._slot, asm._slot_ok)
    asm._seen_start = asm._seen_position


def _build(
    units: SurfaceUnits,
    t: list[float],
    cid: list[int],
    x: np.ndarray,
    y: np.ndarray,
    p: np.ndarray | None,
    p_none: np.ndarray | None,
    tool: Sequence[int],
    tip: list[bool],
    in_range: list[bool],
    tilt: tuple[np.ndarray, np.ndarray] | None,
    buttons: list[int],
) -> list[PenSample]:
    """PenSamples from columns in device units: units.sample's arithmetic, as arrays."""
    x0, x1, y0, y1 = units._bounds
    xs = ((np.minimum(np.maximum(x, x0), x1) - x0) / units._rx / 1000).tolist()
    ys = ((np.minimum(np.maximum(y, y0), y1) - y0) / units._ry / 1000).tolist()
    n = len(xs)
    ps: list[Any]
    if p is None or units._pressure is None:
        ps = [None] * n
    else:
        pf = (p - units._pressure.offset) * units._pressure.scale
        ps = np.minimum(np.maximum(pf, 0.0), 1.0).tolist()
        if p_none is not None and p_none.any():
            for i in np.flatnonzero(p_none).tolist():
                ps[i] = None
    txs: list[Any]
    tys: list[Any]
    if tilt is not None and units._tilt_x is not None:
        txs = ((tilt[0] - units._tilt_x.offset) * units._tilt_x.scale).tolist()
    else:
        txs = [None] * n
    if tilt is not None and units._tilt_y is not None:
        tys = ((tilt[1] - units._tilt_y.offset) * units._tilt_y.scale).tolist()
    else:
        tys = [None] * n
    tools = _TOOLS
    blank = BlankSample
    pen_sample = PenSample
    out: list[PenSample] = []
    append = out.append
    for ti, xi, yi, tp, ir, ci, pi, tl, tx, ty, b in zip(
        t, xs, ys, tip, in_range, cid, ps, tool, txs, tys, buttons, strict=True
    ):
        s: Any = blank()
        s.t = ti
        s.x = xi
        s.y = yi
        s.tip = tp
        s.in_range = ir
        s.contact = ci
        s.pressure = pi
        s.tool = tools[tl]
        s.tilt_x = tx
        s.tilt_y = ty
        s.buttons = b
        s.__class__ = pen_sample
        append(s)
    return out


def _times(ev: np.ndarray, reports: np.ndarray) -> np.ndarray:
    """Frame.time of each frame: sec + usec / 1e6, as Python computes it."""
    at = ev[reports]
    t: np.ndarray = at["sec"].astype(np.float64) + at["usec"].astype(np.float64) / 1_000_000
    return t


def _single(
    asm: FrameAssembler,
    units: SurfaceUnits,
    ev: np.ndarray,
    reports: np.ndarray,
    frame_t: np.ndarray,
    retime: Retime | None,
) -> list[PenSample] | None:
    """A device without slots: one contact (id 0) while a tool is in range."""
    plan = _plan(asm)
    where, c, v, known, unknown = _abs_events(plan, ev)
    kept = where[known]
    kc, kv = c[known], v[known]
    out_of_range = int(np.count_nonzero((kv < plan.lo[kc]) | (kv > plan.hi[kc])))
    rank = plan.rank[kc]
    codes = plan.codes
    n_rows = reports.size + 1
    rows = np.concatenate(([-1], reports))
    init = np.asarray([asm._abs[c] for c in codes], np.int64)
    index = _Index(rank, kept, kv, ev.size, init)
    vals = index.get(np.arange(plan.n_frame)[None, :], rows[:, None])
    final = index.get(np.arange(len(codes)), reports[-1])
    tool_k, touch_k, buttons_k, keys, unknown_k, bad = _keys(asm, ev, reports)
    # seen a position (devices without tool keys are in range from then on)
    xy = kept[kc <= _Y]
    if asm._seen_position:
        seen = np.ones(n_rows, bool)
    elif xy.size:
        seen = rows > xy[0]
    else:
        seen = np.zeros(n_rows, bool)
    in_range = np.where(seen, _TOOL_INDEX[asm._default_tool], 0)
    tool = tool_k if asm._has_tool_keys else in_range

    def col(code: int) -> np.ndarray | None:
        return vals[:, codes.index(code)] if code in codes else None

    zero = np.zeros(n_rows, np.int64)
    x = col(_X)
    y = col(_Y)
    x = zero if x is None else x
    y = zero if y is None else y
    p = col(_P) if asm._has_pressure else None
    if asm._has_touch_key:
        tip = touch_k
    elif p is not None:
        tip = p > asm._pressure_min
    else:
        tip = np.zeros(n_rows, bool)
    tilt = (vals[:, codes.index(_TX)], vals[:, codes.index(_TY)]) if asm._has_tilt else None
    present = tool != 0
    # the batch's start must be the assembler's last frame (the invariant above)
    first = _single_contact(asm, x, y, p, tip, tool, tilt, buttons_k, 0) if present[0] else None
    if (first,) != (asm._last[0] if asm._last else None,):
        return None
    ended = ~present[1:] & present[:-1]
    # sample rows: each frame's ended contact (the row before) or its contact
    src = np.flatnonzero(present[1:] | ended) + 1
    is_end = ended[src - 1]
    row = src - is_end  # an ended contact's values are the previous frame's
    if retime is not None:
        frame_t = retime(frame_t)
    times = frame_t[src - 1].tolist()
    n = src.size
    made = _build(
        units,
        times,
        [0] * n,
        x[row],
        y[row],
        None if p is None else p[row],
        None,
        tool[row].tolist(),
        (tip[row] & ~is_end).tolist(),
        (~is_end).tolist(),
        None if tilt is None else (tilt[0][row], tilt[1][row]),
        buttons_k[row].tolist(),
    )
    # the assembler's state as feed_many leaves it
    for code, value in zip(codes, final.tolist(), strict=True):
        asm._abs[code] = value
    asm._keys.clear()
    asm._keys.update(keys)
    asm._seen_position = bool(seen[-1])
    asm._last = (
        (_single_contact(asm, x, y, p, tip, tool, tilt, buttons_k, n_rows - 1),)
        if present[-1]
        else ()
    )
    _finish(asm, reports.size, unknown + unknown_k, out_of_range, bad)
    return made


def _single_contact(
    asm: FrameAssembler,
    x: np.ndarray,
    y: np.ndarray,
    p: np.ndarray | None,
    tip: np.ndarray,
    tool: np.ndarray,
    tilt: tuple[np.ndarray, np.ndarray] | None,
    buttons: np.ndarray,
    r: int,
) -> Contact:
    return Contact(
        0,
        None,
        None,
        _TOOLS[int(tool[r])],  # type: ignore[arg-type]
        int(x[r]),
        int(y[r]),
        None if p is None else int(p[r]),
        bool(tip[r]),
        True,
        None if tilt is None else int(tilt[0][r]),
        None if tilt is None else int(tilt[1][r]),
        int(buttons[r]),
    )


def _multitouch(
    asm: FrameAssembler,
    units: SurfaceUnits,
    ev: np.ndarray,
    reports: np.ndarray,
    frame_t: np.ndarray,
    retime: Retime | None,
) -> list[PenSample] | None:
    """Protocol B: a contact per slot with a tracking id that is not a palm."""
    if not asm._slot_ok:
        return None
    plan = _plan(asm)
    where, c, v, known, _ = _abs_events(plan, ev)
    is_slot = c == ABS_MT_SLOT
    num_slots = asm.num_slots
    if np.any(is_slot & ((v < 0) | (v >= num_slots))):
        return None
    # the slot each event addresses: the last ABS_MT_SLOT before it
    slot_at = np.where(is_slot, np.arange(where.size), -1)
    np.maximum.accumulate(slot_at, out=slot_at)
    slot = np.where(slot_at >= 0, v[np.maximum(slot_at, 0)], asm._slot) if v.size else v
    mt = c > ABS_MT_SLOT
    unknown = int(np.count_nonzero(~known & ~is_slot))
    value_ev = mt & known
    checked = value_ev & (c != ABS_MT_TRACKING_ID)
    out_of_range = int(np.count_nonzero(checked & ((v < plan.lo[c]) | (v > plan.hi[c]))))
    rank = plan.rank[c]
    kept = value_ev & (rank >= 0)
    k_at, k_slot, k_rank, k_val = where[kept], slot[kept], rank[kept], v[kept].copy()
    codes = plan.codes
    nc = len(codes)
    # tracking ids, one by one as _set_slot_value applies them
    tids = [s.tid for s in asm._slots]
    replaced = reused = 0
    if ABS_MT_TRACKING_ID in codes:
        tid_rank = codes.index(ABS_MT_TRACKING_ID)
        tid_pos = np.flatnonzero(k_rank == tid_rank)
        for i, s, value in zip(
            tid_pos.tolist(), k_slot[tid_pos].tolist(), k_val[tid_pos].tolist(), strict=True
        ):
            old = tids[s]
            if value < 0:
                new = -1
            elif value != old and value in tids:
                reused += 1
                new = -1
            else:
                if value != old and old >= 0:
                    replaced += 1
                new = value
            tids[s] = new
            k_val[i] = new
    # the slots that may hold a contact in this batch, in slot order
    in_use = np.zeros(num_slots, bool)
    in_use[k_slot] = True
    for i, st in enumerate(asm._slots):
        if st.tid >= 0:
            in_use[i] = True
    used = np.flatnonzero(in_use)
    nu = used.size
    if nu == 0:
        if asm._last:
            return None
        if retime is not None:
            retime(frame_t)  # a replay's pause compression sees every frame
        return _mt_empty(asm, reports, unknown, out_of_range, replaced, reused, ev)
    slot_pos = np.full(num_slots, -1, np.int64)
    slot_pos[used] = np.arange(nu)
    init = np.empty(nu * nc, np.int64)
    for j, s_no in enumerate(used.tolist()):
        st = asm._slots[s_no]
        now = {
            ABS_MT_TRACKING_ID: st.tid,
            ABS_MT_POSITION_X: st.x,
            ABS_MT_POSITION_Y: st.y,
            ABS_MT_PRESSURE: st.pressure,
            ABS_MT_DISTANCE: st.distance,
            ABS_MT_TOOL_TYPE: st.tool_type,
        }
        for r, code in enumerate(codes):
            val = now[code]
            init[j * nc + r] = _NONE if val is None else val
    index = _Index(slot_pos[k_slot] * nc + k_rank, k_at, k_val, ev.size, init)
    rows = np.concatenate(([-1], reports))
    n_rows = rows.size
    first_key = np.arange(nu) * nc

    def grid(code: int, default: int) -> np.ndarray:
        """[row, used slot] of one code: wanted for every slot at every frame."""
        if code not in codes:
            return np.full((n_rows, nu), default, np.int64)
        return index.get(first_key[None, :] + codes.index(code), rows[:, None])

    tid = grid(ABS_MT_TRACKING_ID, -1)
    tool_type = grid(ABS_MT_TOOL_TYPE, 0)
    active = (tid >= 0) & (tool_type != MT_TOOL_PALM)
    # the rest only where a contact is: (row, slot) pairs in row-major order
    pr, pj = np.nonzero(active)
    n_pairs = pr.size

    def pairs(code: int, default: int) -> np.ndarray:
        if code not in codes:
            return np.full(n_pairs, default, np.int64)
        return index.get(first_key[pj] + codes.index(code), rows[pr])

    ptid = tid[pr, pj]
    ptool = np.where(
        tool_type[pr, pj] == MT_TOOL_PEN, _TOOL_INDEX[Tool.PEN], _TOOL_INDEX[Tool.FINGER]
    )
    px = pairs(ABS_MT_POSITION_X, 0)
    py = pairs(ABS_MT_POSITION_Y, 0)
    has_p = asm._has_mt_pressure
    pp = pairs(ABS_MT_PRESSURE, 0)
    ptip = pairs(ABS_MT_DISTANCE, 0) == 0
    _, _, buttons_k, keys, unknown_k, bad = _keys(asm, ev, reports)
    pbuttons = buttons_k[pr]
    row_start = np.searchsorted(pr, np.arange(n_rows + 1))

    def contacts(r: int) -> tuple[Contact, ...]:
        a, b = int(row_start[r]), int(row_start[r + 1])
        return tuple(
            _tnew(
                Contact,
                (t, int(used[j]), t, _TOOLS[tl], xx, yy, pv, tp, True, None, None, bt),
            )
            for t, j, tl, xx, yy, pv, tp, bt in zip(
                ptid[a:b].tolist(),
                pj[a:b].tolist(),
                ptool[a:b].tolist(),
                px[a:b].tolist(),
                py[a:b].tolist(),
                [None if v == _NONE else v for v in pp[a:b].tolist()]
                if has_p
                else [None] * (b - a),
                ptip[a:b].tolist(),
                pbuttons[a:b].tolist(),
                strict=True,
            )
        )

    if contacts(0) != asm._last:
        return None
    # ended: active in the row before, its id active nowhere in this row
    prev_tid = np.where(active[:-1], tid[:-1], -1)
    cur_tid = np.where(active[1:], tid[1:], -2)
    still = (prev_tid[:, :, None] == cur_tid[:, None, :]).any(axis=2)
    ended = active[:-1] & ~still
    # sample order: per frame, ended contacts (slot order), then current ones
    ef, ej = np.nonzero(ended)
    cf, cj = np.nonzero(active[1:])
    frame = np.concatenate((ef, cf))
    is_end = np.concatenate((np.ones(ef.size, bool), np.zeros(cf.size, bool)))
    sj = np.concatenate((ej, cj))
    order = np.argsort((frame * 2 + ~is_end) * nu + sj, kind="stable")
    frame, is_end, sj = frame[order], is_end[order], sj[order]
    pair_id = np.full((n_rows, nu), -1, np.int64)
    pair_id[pr, pj] = np.arange(n_pairs)
    pid = pair_id[frame + 1 - is_end, sj]
    if retime is not None:
        frame_t = retime(frame_t)
    times = frame_t[frame].tolist()
    pv = pp[pid]
    made = _build(
        units,
        times,
        ptid[pid].tolist(),
        px[pid],
        py[pid],
        pv if has_p else None,
        pv == _NONE if has_p else None,
        ptool[pid].tolist(),
        (ptip[pid] & ~is_end).tolist(),
        (~is_end).tolist(),
        None,
        pbuttons[pid].tolist(),
    )
    # the assembler's state as feed_many leaves it
    final = index.get(np.arange(nu * nc), reports[-1]).reshape(nu, nc)
    for j, s_no in enumerate(used.tolist()):
        st = asm._slots[s_no]
        for r, code in enumerate(codes):
            value = int(final[j, r])
            if code == ABS_MT_TRACKING_ID:
                st.tid = value
            elif code == ABS_MT_POSITION_X:
                st.x = value
            elif code == ABS_MT_POSITION_Y:
                st.y = value
            elif code == ABS_MT_PRESSURE:
                st.pressure = None if value == _NONE else value
            elif code == ABS_MT_DISTANCE:
                st.distance = value
            else:
                st.tool_type = value
    _mt_state(asm, ev, where, is_slot, v, keys)
    asm._last = contacts(rows.size - 1)
    _mt_counts(asm, replaced, reused)
    _finish(asm, reports.size, unknown + unknown_k, out_of_range, bad)
    return made


def _mt_state(
    asm: FrameAssembler,
    ev: np.ndarray,
    where: np.ndarray,
    is_slot: np.ndarray,
    v: np.ndarray,
    keys: set[int],
) -> None:
    slots = np.flatnonzero(is_slot)
    if slots.size:
        asm._slot = int(v[slots[-1]])
        asm._slot_ok = True
    asm._keys.clear()
    asm._keys.update(keys)


def _mt_counts(asm: FrameAssembler, replaced: int, reused: int) -> None:
    if replaced:
        asm._counts["tracking_id_replaced"] += replaced
    if reused:
        asm._counts["tracking_id_reused"] += reused


def _mt_empty(
    asm: FrameAssembler,
    reports: np.ndarray,
    unknown: int,
    out_of_range: int,
    replaced: int,
    reused: int,
    ev: np.ndarray,
) -> list[PenSample] | None:
    """No slot holds or takes a tracking id: no contact in any frame."""
    plan = _plan(asm)
    where, c, v, _, _ = _abs_events(plan, ev)
    _, _, _, keys, unknown_k, bad = _keys(asm, ev, reports)
    _mt_state(asm, ev, where, c == ABS_MT_SLOT, v, keys)
    _mt_counts(asm, replaced, reused)
    _finish(asm, reports.size, unknown + unknown_k, out_of_range, bad)
    return []
