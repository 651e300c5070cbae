"""A large read() -> PenSamples in one compiled pass: Python runs per sample, not per event.

The frame assembler (frames.py) runs Python for every event: five of them
for a pen frame, more for a touchpad. When one read() holds many frames (a
replay, or a live reader that fell behind), the bytes are instead read in
place as arrays and walked by a loop compiled with numba
(columns_kernel.py) that applies every event to a copy of the assembler's
state, exactly as feed_many_general does, and writes each frame's samples
as columns in surface units. Python then only builds the PenSamples.

A first version found the state at each SYN_REPORT with numpy alone (one
searchsorted over (key, event index) for every axis and slot): about 130
array operations per batch at a microsecond or two each, and still a
microsecond per frame -- 2.1 us per frame pooled, where the compiled loop
costs a few microseconds per batch and a few tens of nanoseconds per event.

The samples are those `frame_samples()` gives for the assembler's frames,
and the assembler is left as feed_many leaves it: its state, counters and
last frame's contacts are copied back (tests/evdev/test_evdev_columns.py
compares both paths on every recording, in many batchings, and on random
streams). A batch the loop refuses -- SYN_DROPPED (the assembler's rollback
and resync), a slot number out of range, a frame in progress at its start,
a start state that does not give the assembler's last frame -- returns None
with nothing changed, and the caller takes the per-event path. Events after
the batch's last SYN_REPORT go to the assembler too (its undo state for a
frame in progress).

Compiling takes seconds the first time (then numba's cache loads it in a
fraction of one): `samples(..., compile=False)` uses the loops only once
they are compiled, so that a live reader never stalls on it.
"""

from __future__ import annotations

import logging
import struct
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
from evdev import ecodes

from stiction.drivers.blank_sample import BlankSample
from stiction.drivers.evdev import columns_kernel as k
from stiction.drivers.evdev.frames import (
    _TOOL_ORDER,
    BUTTON_BITS,
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


def _numba_ok() -> bool:
    try:
        import numba  # type: ignore[import-untyped]  # noqa: F401
    except ImportError:
        return False
    return True


#: the layout above is the native one, and numba is there (else: the per-event path)
AVAILABLE = struct.calcsize("@llHHi") == EVENT.itemsize and struct.calcsize("@l") == 8
AVAILABLE = AVAILABLE and _numba_ok()

#: a read of fewer events goes the per-event way: the compiled loop's call and
#: the arrays around it cost about what the assembler spends on a few frames
MIN_EVENTS = 48

_TOOLS: tuple[Tool | None, ...] = (None, *Tool)
_TOOL_INDEX = {t: i for i, t in enumerate(_TOOLS)}
_TOOL_CODES = np.array([code for code, _ in _TOOL_ORDER], np.int64)
_TOOL_OF = np.array([_TOOL_INDEX[t] for _, t in _TOOL_ORDER], np.int64)
_BUTTON_CODES = np.array(list(BUTTON_BITS), np.int64)
_BUTTON_BITS = np.array(list(BUTTON_BITS.values()), np.int64)
_X, _Y, _P, _TX, _TY = (
    ecodes.ABS_X,
    ecodes.ABS_Y,
    ecodes.ABS_PRESSURE,
    ecodes.ABS_TILT_X,
    ecodes.ABS_TILT_Y,
)

Retime = Callable[[np.ndarray], np.ndarray]

log = logging.getLogger(__name__)

_lock = threading.Lock()
_kernels: dict[str, Any] = {}


def kernels() -> dict[str, Any]:
    """The loops as numba dispatchers (each compiled, or loaded from numba's cache,
    at its first call)."""
    with _lock:
        if not _kernels:
            import numba

            # numba's own cache: beside this package, or the user's cache folder
            # when that is not writable; keyed by columns_kernel.py's stamp, which
            # is enough here: the loops call nothing outside that file.
            _kernels["single"] = numba.njit(cache=True)(k.single)
            _kernels["multitouch"] = numba.njit(cache=True)(k.multitouch)
        return _kernels


def compiled(kind: str | None = None) -> bool:
    """Has the loop for `kind` ("single", "multitouch"; None: both) been compiled
    (or loaded) in this process?"""
    names = ("single", "multitouch") if kind is None else (kind,)
    return all(n in _kernels and bool(_kernels[n].signatures) for n in names)


def _run(kind: str, *args: Any) -> int:
    """One loop over one batch; -6 when numba fails (then never again in this process)."""
    global AVAILABLE
    try:
        n: int = kernels()[kind](*args)
    except Exception:  # a numba that cannot compile here: the per-event path still works
        log.exception("evdev: the compiled %s loop failed; reading event by event", kind)
        AVAILABLE = False
        return -6
    return n


def warm() -> None:
    """Compile (or load) both loops now, on a tiny batch of each kind."""
    from stiction.drivers.evdev.description import AbsAxis, DeviceDescription

    e = ecodes
    axes = {e.ABS_X: AbsAxis(0, 0, 100, resolution=1), e.ABS_Y: AbsAxis(0, 0, 100, resolution=1)}
    mt = {
        **axes,
        e.ABS_MT_SLOT: AbsAxis(0, 0, 1),
        e.ABS_MT_TRACKING_ID: AbsAxis(0, 0, 100),
        e.ABS_MT_POSITION_X: AbsAxis(0, 0, 100, resolution=1),
        e.ABS_MT_POSITION_Y: AbsAxis(0, 0, 100, resolution=1),
    }
    for desc_axes in (axes, mt):
        desc = DeviceDescription(name="warm-up", keys=frozenset({e.BTN_TOUCH}), axes=desc_axes)
        data = struct.pack("@llHHi", 0, 0, e.EV_SYN, e.SYN_REPORT, 0)
        samples(FrameAssembler(desc), SurfaceUnits(desc), data)


class _Plan:
    """Per-device tables: made once per kind of device (the device never changes)."""

    def __init__(self, asm: FrameAssembler) -> None:
        n = k.N_ABS
        self.known = np.zeros(n, np.int64)
        self.lo = np.zeros(n, np.int64)
        self.hi = np.zeros(n, np.int64)
        for code, (lo, hi) in asm._ranges.items():
            if code < n:
                self.known[code] = 1
                self.lo[code], self.hi[code] = lo, hi
        #: single-tool: every axis kept in `cur`, in this order
        self.codes = sorted(c for c in asm._abs if c < n)
        self.rank = np.full(n, -1, np.int64)
        for i, c in enumerate(self.codes):
            self.rank[c] = i
        self.key_ok = np.zeros(k.N_KEYS, np.int8)
        for code in asm._valid_keys:
            if code < k.N_KEYS:
                self.key_ok[code] = 1
        cfg = np.zeros(k.N_CFG, np.int64)
        for slot, code in ((k.C_X, _X), (k.C_Y, _Y), (k.C_P, _P), (k.C_TX, _TX), (k.C_TY, _TY)):
            cfg[slot] = self.codes.index(code) if code in self.codes else -1
        if not asm._has_pressure:
            cfg[k.C_P] = -1
        if not asm._has_tilt:
            cfg[k.C_TX] = cfg[k.C_TY] = -1
        cfg[k.C_HAS_TOOL_KEYS] = asm._has_tool_keys
        cfg[k.C_DEFAULT_TOOL] = _TOOL_INDEX[asm._default_tool]
        cfg[k.C_TIP_MODE] = 1 if asm._has_touch_key else 2 if asm._has_pressure else 0
        cfg[k.C_P_MIN] = asm._pressure_min
        cfg[k.C_TOUCH] = ecodes.BTN_TOUCH
        cfg[k.C_PEN_TOOL] = _TOOL_INDEX[Tool.PEN]
        cfg[k.C_FINGER_TOOL] = _TOOL_INDEX[Tool.FINGER]
        cfg[k.C_HAS_MT_P] = asm._has_mt_pressure
        self.cfg = cfg
        # device codes the key set may hold (bad ones never enter it)
        self.multitouch = asm.multitouch
        self.num_slots = asm.num_slots


_PLANS: dict[tuple[object, ...], _Plan] = {}


def _plan(asm: FrameAssembler) -> _Plan:
    mine: _Plan | None = asm.__dict__.get("_columns_plan")
    if mine is not None:
        return mine
    key = (
        asm.multitouch,
        asm.num_slots,
        tuple(sorted(asm._ranges.items())),
        tuple(sorted(asm._abs)),
        asm._valid_keys,
        asm._has_tool_keys,
        asm._has_touch_key,
        asm._has_pressure,
        asm._has_mt_pressure,
        asm._has_tilt,
        asm._pressure_min,
        asm._default_tool,
    )
    plan = _PLANS.get(key)
    if plan is None:
        plan = _PLANS[key] = _Plan(asm)
    asm.__dict__["_columns_plan"] = plan  # the next batch of this device skips the key
    return plan


def _units_cfg(units: SurfaceUnits) -> np.ndarray:
    """units.sample's numbers, for the loops (the absent scales never used: None then)."""
    mine: np.ndarray | None = units.__dict__.get("_columns_cfg")
    if mine is not None:
        return mine
    f = np.zeros(k.N_FCFG)
    f[k.F_X0], f[k.F_X1], f[k.F_Y0], f[k.F_Y1] = units._bounds
    f[k.F_RX], f[k.F_RY] = units._rx, units._ry
    for off, scale, lin in (
        (k.F_P_OFF, k.F_P_SCALE, units._pressure),
        (k.F_TX_OFF, k.F_TX_SCALE, units._tilt_x),
        (k.F_TY_OFF, k.F_TY_SCALE, units._tilt_y),
    ):
        if lin is not None:
            f[off], f[scale] = lin.offset, lin.scale
    for lo, hi, lin in (
        (k.F_TX_LO, k.F_TX_HI, units._tilt_x),
        (k.F_TY_LO, k.F_TY_HI, units._tilt_y),
    ):
        if lin is not None:
            f[lo], f[hi] = lin.lo, lin.hi
    units.__dict__["_columns_cfg"] = f
    return f


def samples(
    asm: FrameAssembler,
    units: SurfaceUnits,
    data: bytes,
    retime: Retime | None = None,
    compile: bool = True,
) -> list[PenSample] | None:
    """The samples of every frame `data` (whole input_events) completes; None: not here.

    None means nothing was consumed and the caller feeds the events through
    the assembler instead (see the module doc for when). `retime`, if given,
    maps the times of all the frames (Frame.time, in order) to the times their
    samples get (a replay's pause compression); it sees every frame, those
    without contacts too. compile=False: None unless the loops are compiled."""
    if not AVAILABLE or asm._dropping or asm._n_pending or len(data) % EVENT.itemsize:
        return None
    if not compile and not compiled("multitouch" if asm.multitouch else "single"):
        return None
    if type(data) is not bytes:
        data = bytes(data)  # read-only arrays: one compiled signature for every caller
    n_ev = len(data) // EVENT.itemsize
    if n_ev == 0:
        return None
    q = np.frombuffer(data, np.int64).reshape(n_ev, 3)
    h = np.frombuffer(data, np.uint16).reshape(n_ev, 12)
    w = np.frombuffer(data, np.int32).reshape(n_ev, 6)
    plan = _plan(asm)
    down = np.zeros(k.N_KEYS, np.int8)
    for code in asm._keys:
        if code < k.N_KEYS:
            down[code] = 1
    cfg = plan.cfg.copy()
    fcfg = _units_cfg(units)
    frame_t = np.empty(n_ev)
    counts = np.zeros(5, np.int64)
    res = np.zeros(2, np.int64)
    if plan.multitouch:
        return _multitouch(asm, units, plan, q, h, w, down, cfg, fcfg, frame_t, counts, res, retime)
    return _single(asm, units, plan, q, h, w, down, cfg, fcfg, frame_t, counts, res, retime)


def _single(
    asm: FrameAssembler,
    units: SurfaceUnits,
    plan: _Plan,
    q: np.ndarray,
    h: np.ndarray,
    w: np.ndarray,
    down: np.ndarray,
    cfg: np.ndarray,
    fcfg: np.ndarray,
    frame_t: np.ndarray,
    counts: np.ndarray,
    res: np.ndarray,
    retime: Retime | None,
) -> list[PenSample] | None:
    """A device without slots: one contact (id 0) while a tool is in range."""
    codes = plan.codes
    cur = np.array([asm._abs[c] for c in codes], np.int64)
    prev = np.zeros(k.N_PREV, np.int64)
    if asm._last:
        c = asm._last[0]
        prev[k.P_TOOL] = _TOOL_INDEX[c.tool]
        prev[k.P_X], prev[k.P_Y] = c.x, c.y
        prev[k.P_P] = c.pressure or 0
        prev[k.P_TIP] = c.tip
        prev[k.P_TLX], prev[k.P_TLY] = c.tilt_x or 0, c.tilt_y or 0
        prev[k.P_BTN] = c.buttons
    cfg[k.C_SEEN] = asm._seen_position
    n_ev = q.shape[0]
    out_i = np.empty((7, n_ev), np.int64)
    out_f = np.empty((5, n_ev))
    n = _run(
        "single",
        q,
        h,
        w,
        plan.rank,
        plan.lo,
        plan.hi,
        cur,
        plan.key_ok,
        down,
        _TOOL_CODES,
        _TOOL_OF,
        _BUTTON_CODES,
        _BUTTON_BITS,
        cfg,
        fcfg,
        prev,
        frame_t,
        out_i,
        out_f,
        counts,
        res,
    )
    if n < 0:
        return None
    has_p = cfg[k.C_P] >= 0 and units._pressure is not None
    has_tx = cfg[k.C_TX] >= 0 and units._tilt_x is not None
    has_ty = cfg[k.C_TY] >= 0 and units._tilt_y is not None
    made = _build(
        _sample_times(frame_t, res, out_i, n, retime),
        out_i,
        out_f,
        n,
        has_p,
        False,
        has_tx,
        has_ty,
    )
    # the assembler's state as feed_many leaves it
    for code, value in zip(codes, cur.tolist(), strict=True):
        asm._abs[code] = value
    asm._seen_position = bool(cfg[k.C_SEEN])
    if prev[k.P_TOOL]:
        p = prev.tolist()
        has_pressure = cfg[k.C_P] >= 0
        tilt = cfg[k.C_TX] >= 0
        asm._last = (
            _tnew(
                Contact,
                (
                    0,
                    None,
                    None,
                    _TOOLS[p[k.P_TOOL]],
                    p[k.P_X],
                    p[k.P_Y],
                    p[k.P_P] if has_pressure else None,
                    bool(p[k.P_TIP]),
                    True,
                    p[k.P_TLX] if tilt else None,
                    p[k.P_TLY] if tilt else None,
                    p[k.P_BTN],
                ),
            ),
        )
    else:
        asm._last = ()
    _finish(asm, down, counts, res, q)
    return made


def _multitouch(
    asm: FrameAssembler,
    units: SurfaceUnits,
    plan: _Plan,
    q: np.ndarray,
    h: np.ndarray,
    w: np.ndarray,
    down: np.ndarray,
    cfg: np.ndarray,
    fcfg: np.ndarray,
    frame_t: np.ndarray,
    counts: np.ndarray,
    res: np.ndarray,
    retime: Retime | None,
) -> list[PenSample] | None:
    """Protocol B: a contact per slot with a tracking id that is not a palm."""
    if not asm._slot_ok:
        return None
    num = plan.num_slots
    slots = np.array(
        [
            (s.tid, s.x, s.y, s.pressure or 0, s.pressure is not None, s.distance, s.tool_type)
            for s in asm._slots
        ],
        np.int64,
    ).reshape(num, 7)
    prev = np.zeros((max(num, 1), k.N_PREV), np.int64)
    for i, c in enumerate(asm._last):
        prev[i, k.P_TID] = c.id
        prev[i, k.P_SLOT] = c.slot or 0  # never None on a multi-touch device
        prev[i, k.P_TOOL] = _TOOL_INDEX[c.tool]
        prev[i, k.P_X], prev[i, k.P_Y] = c.x, c.y
        prev[i, k.P_P] = c.pressure or 0
        prev[i, k.P_PNONE] = c.pressure is None
        prev[i, k.P_TIP] = c.tip
        prev[i, k.P_BTN] = c.buttons
    prev_n = np.array([len(asm._last)], np.int64)
    cfg[k.C_SLOT] = asm._slot
    n_ev = q.shape[0]
    room = 2 * n_ev
    while True:
        out_i = np.empty((7, room), np.int64)
        out_f = np.empty((5, room))
        n = _run(
            "multitouch",
            q,
            h,
            w,
            plan.known,
            plan.lo,
            plan.hi,
            final_slots := slots.copy(),
            plan.key_ok,
            final_down := down.copy(),
            _BUTTON_CODES,
            _BUTTON_BITS,
            cfg,
            fcfg,
            work := prev.copy(),
            work_n := prev_n.copy(),
            frame_t,
            out_i,
            out_f,
            counts,
            res,
        )
        if n != -5:
            break
        room = 2 * n_ev * max(num, 1)  # every slot's contact ending in every frame
        counts[:] = 0
        cfg[k.C_SLOT] = asm._slot
    if n < 0:
        return None
    has_p = bool(cfg[k.C_HAS_MT_P]) and units._pressure is not None
    made = _build(
        _sample_times(frame_t, res, out_i, n, retime), out_i, out_f, n, has_p, True, False, False
    )
    # the assembler's state as feed_many leaves it
    for st, (tid, x, y, p, p_set, dist, tool_type) in zip(
        asm._slots, final_slots.tolist(), strict=True
    ):
        st.tid, st.x, st.y = tid, x, y
        st.pressure = p if p_set else None
        st.distance, st.tool_type = dist, tool_type
    asm._slot = int(cfg[k.C_SLOT])
    asm._slot_ok = True
    has_mt_p = bool(cfg[k.C_HAS_MT_P])
    asm._last = tuple(
        _tnew(
            Contact,
            (
                c[k.P_TID],
                c[k.P_SLOT],
                c[k.P_TID],
                _TOOLS[c[k.P_TOOL]],
                c[k.P_X],
                c[k.P_Y],
                None if c[k.P_PNONE] or not has_mt_p else c[k.P_P],
                bool(c[k.P_TIP]),
                True,
                None,
                None,
                c[k.P_BTN],
            ),
        )
        for c in work[: int(work_n[0])].tolist()
    )
    _finish(asm, final_down, counts, res, q)
    return made


def _sample_times(
    frame_t: np.ndarray, res: np.ndarray, out_i: np.ndarray, n: int, retime: Retime | None
) -> list[float]:
    ft = frame_t[: int(res[0])]
    if retime is not None:
        ft = retime(ft)
    times: list[float] = ft[out_i[k.O_FRAME, :n]].tolist()
    return times


def _build(
    times: list[float],
    out_i: np.ndarray,
    out_f: np.ndarray,
    n: int,
    has_p: bool,
    p_none: bool,
    has_tx: bool,
    has_ty: bool,
) -> list[PenSample]:
    """PenSamples from the loop's columns (already in surface units)."""
    none = [None] * n
    ps: list[Any] = out_f[k.O_P, :n].tolist() if has_p else none
    if has_p and p_none:
        for i in np.flatnonzero(out_i[k.O_PNONE, :n]).tolist():
            ps[i] = None
    tools = _TOOLS
    blank = BlankSample
    pen_sample = PenSample
    out: list[PenSample] = []
    append = out.append
    for ti, xi, yi, tp, ir, ci, pi, tl, tx, ty, b in zip(
        times,
        out_f[k.O_X, :n].tolist(),
        out_f[k.O_Y, :n].tolist(),
        out_i[k.O_TIP, :n].astype(bool).tolist(),
        out_i[k.O_IN, :n].astype(bool).tolist(),
        out_i[k.O_CID, :n].tolist(),
        ps,
        out_i[k.O_TOOL, :n].tolist(),
        out_f[k.O_TX, :n].tolist() if has_tx else none,
        out_f[k.O_TY, :n].tolist() if has_ty else none,
        out_i[k.O_BTN, :n].tolist(),
        strict=True,
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


def _finish(
    asm: FrameAssembler, down: np.ndarray, counts: np.ndarray, res: np.ndarray, q: np.ndarray
) -> None:
    """Counters, keys and the per-frame flags as feed_many leaves them; then the tail."""
    c = asm._counts
    unknown, out_of_range, bad, replaced, reused = counts.tolist()
    for name, value in (
        ("unknown_code", unknown),
        ("value_out_of_range", out_of_range),
        ("bad_key_value", bad),
        ("tracking_id_replaced", replaced),
        ("tracking_id_reused", reused),
    ):
        if value:
            c[name] += value
    keys = asm._keys
    keys.clear()  # in place: feed_many_general holds a reference
    keys.update(np.flatnonzero(down).tolist())
    asm._frames += int(res[0])
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
    end = int(res[1])
    if end < q.shape[0]:
        tail = q[end:]
        h = tail.view(np.uint16).reshape(-1, 12)
        w = tail.view(np.int32).reshape(-1, 6)
        asm.feed_many_general(
            list(
                zip(
                    tail[:, 0].tolist(),
                    tail[:, 1].tolist(),
                    h[:, 8].tolist(),
                    h[:, 9].tolist(),
                    w[:, 5].tolist(),
                    strict=True,
                )
            )
        )
