"""The compiled loops of columns.py: a read()'s events -> sample columns, per device kind.

Plain Python written for numba (columns.py compiles them with
numba.njit(cache=True); they call nothing outside this file, so numba's
stamp of this file keys the cache soundly): each walks the events once, applies them to
the device state exactly as FrameAssembler.feed_many_general does (same
counters, same key, slot and tracking-id rules), and at every SYN_REPORT
writes that frame's samples -- ended contacts first, from the previous
frame's contacts, then the current ones -- as columns, already in surface
units with units.py's arithmetic, operation for operation. Nothing here
touches the assembler; columns.py copies the state back when a loop
succeeds, so a refusal (negative return) leaves everything as it was.

The events are read in place from the read()'s bytes, seen three ways:
`q` as int64[n, 3] (sec, usec, type|code|value), `h` as uint16[n, 12]
(type at 8, code at 9), `w` as int32[n, 6] (value at 5).

Return values: the number of samples, or
  -1  the state the batch starts from does not give the assembler's last frame
  -2  SYN_DROPPED (the assembler's rollback is needed)
  -3  a slot number out of range
  -4  no SYN_REPORT (nothing to do)
  -5  more samples than `out_i` and `out_f` have room for
`res` gets the number of frames and the index after the last SYN_REPORT
(the events after it are left to the assembler).
"""

from __future__ import annotations

from typing import Any

Array = Any

# cfg / fcfg indices shared with columns.py
C_X, C_Y, C_P, C_TX, C_TY = 0, 1, 2, 3, 4  # ranks of those axes in `cur`, -1: none
C_HAS_TOOL_KEYS = 5
C_DEFAULT_TOOL = 6
C_TIP_MODE = 7  # 0: False, 1: BTN_TOUCH, 2: pressure > C_P_MIN
C_P_MIN = 8
C_SEEN = 9
C_TOUCH = 10  # BTN_TOUCH's code
C_SLOT = 11  # multi-touch: the current slot
C_PEN_TOOL, C_FINGER_TOOL = 12, 13  # tool indices
C_HAS_MT_P = 14
N_CFG = 15
F_X0, F_X1, F_Y0, F_Y1, F_RX, F_RY = 0, 1, 2, 3, 4, 5
F_P_OFF, F_P_SCALE, F_TX_OFF, F_TX_SCALE, F_TY_OFF, F_TY_SCALE = 6, 7, 8, 9, 10, 11
F_TX_LO, F_TX_HI, F_TY_LO, F_TY_HI = 12, 13, 14, 15  # tilt's clamp, in degrees
N_FCFG = 16
# prev (the last frame's contact(s)): fields per contact
P_TID, P_SLOT, P_TOOL, P_X, P_Y, P_P, P_PNONE, P_TIP, P_TLX, P_TLY, P_BTN = range(11)
N_PREV = 11
# out_i rows, out_f rows
O_FRAME, O_CID, O_TOOL, O_TIP, O_IN, O_BTN, O_PNONE = range(7)
O_X, O_Y, O_P, O_TX, O_TY = range(5)
# counts
K_UNKNOWN, K_RANGE, K_BADKEY, K_REPLACED, K_REUSED = range(5)

ABS_MT_SLOT = 0x2F
ABS_MT_POSITION_X = 0x35
ABS_MT_POSITION_Y = 0x36
ABS_MT_TRACKING_ID = 0x39
ABS_MT_PRESSURE = 0x3A
ABS_MT_DISTANCE = 0x3B
ABS_MT_TOOL_TYPE = 0x37
MT_TOOL_PEN = 1
MT_TOOL_PALM = 2
N_KEYS = 0x300  # KEY_CNT: key codes above are unknown to every device
N_ABS = 0x40  # ABS_CNT


def single(
    q: Array,
    h: Array,
    w: Array,
    rank: Array,
    lo: Array,
    hi: Array,
    cur: Array,
    key_ok: Array,
    down: Array,
    tool_codes: Array,
    tool_of: Array,
    button_codes: Array,
    button_bits: Array,
    cfg: Array,
    fcfg: Array,
    prev: Array,
    frame_t: Array,
    out_i: Array,
    out_f: Array,
    counts: Array,
    res: Array,
) -> int:  # pragma: no cover - compiled
    """A device without slots: one contact (id 0) while a tool is in range."""
    end = 0
    for i in range(h.shape[0] - 1, -1, -1):
        if h[i, 8] == 0 and h[i, 9] == 0:
            end = i + 1
            break
    if end == 0:
        return -4
    rx_, ry_, rp, rtx, rty = cfg[C_X], cfg[C_Y], cfg[C_P], cfg[C_TX], cfg[C_TY]
    has_tool_keys = cfg[C_HAS_TOOL_KEYS] != 0
    tip_mode = cfg[C_TIP_MODE]
    p_min = cfg[C_P_MIN]
    seen = cfg[C_SEEN] != 0
    touch_code = cfg[C_TOUCH]
    x0, x1, y0, y1 = fcfg[F_X0], fcfg[F_X1], fcfg[F_Y0], fcfg[F_Y1]
    rx, ry = fcfg[F_RX], fcfg[F_RY]
    p_off, p_scale = fcfg[F_P_OFF], fcfg[F_P_SCALE]
    tx_off, tx_scale = fcfg[F_TX_OFF], fcfg[F_TX_SCALE]
    ty_off, ty_scale = fcfg[F_TY_OFF], fcfg[F_TY_SCALE]
    tx_lo, tx_hi, ty_lo, ty_hi = fcfg[F_TX_LO], fcfg[F_TX_HI], fcfg[F_TY_LO], fcfg[F_TY_HI]
    ix0, ix1, iy0, iy1 = int(x0), int(x1), int(y0), int(y1)
    key_tool = 0
    for k in range(tool_codes.shape[0]):
        if down[tool_codes[k]]:
            key_tool = tool_of[k]
            break
    touch = down[touch_code] != 0
    buttons = 0
    for k in range(button_codes.shape[0]):
        if down[button_codes[k]]:
            buttons |= button_bits[k]
    present_before = prev[P_TOOL] != 0
    n = 0
    f = 0
    for i in range(-1, end):
        if i >= 0:
            typ = h[i, 8]
            code = h[i, 9]
            if typ == 3:
                if code < N_ABS and rank[code] >= 0:
                    value = w[i, 5]
                    cur[rank[code]] = value
                    if value < lo[code] or value > hi[code]:
                        counts[K_RANGE] += 1
                    if code <= 1:
                        seen = True
                else:
                    counts[K_UNKNOWN] += 1
                continue
            if typ == 1:
                code_ok = code < N_KEYS and key_ok[code] != 0
                value = w[i, 5]
                if not code_ok:
                    counts[K_UNKNOWN] += 1
                    continue
                if value == 0:
                    down[code] = 0
                elif value == 1 or value == 2:
                    down[code] = 1
                else:
                    counts[K_BADKEY] += 1
                    continue
                key_tool = 0
                for k in range(tool_codes.shape[0]):
                    if down[tool_codes[k]]:
                        key_tool = tool_of[k]
                        break
                touch = down[touch_code] != 0
                buttons = 0
                for k in range(button_codes.shape[0]):
                    if down[button_codes[k]]:
                        buttons |= button_bits[k]
                continue
            if typ != 0:
                continue
            if code == 3:
                return -2
            if code != 0:
                continue
        # a SYN_REPORT (or, at i == -1, the state the batch starts from)
        if has_tool_keys:
            tool = key_tool
        elif seen:
            tool = cfg[C_DEFAULT_TOOL]
        else:
            tool = 0
        x = cur[rx_] if rx_ >= 0 else 0
        y = cur[ry_] if ry_ >= 0 else 0
        p = cur[rp] if rp >= 0 else 0
        if tip_mode == 1:
            tip = touch
        elif tip_mode == 2:
            tip = p > p_min
        else:
            tip = False
        tlx = cur[rtx] if rtx >= 0 else 0
        tly = cur[rty] if rty >= 0 else 0
        if i < 0:
            if tool != prev[P_TOOL]:
                return -1
            if tool != 0 and (
                x != prev[P_X]
                or y != prev[P_Y]
                or p != prev[P_P]
                or int(tip) != prev[P_TIP]
                or tlx != prev[P_TLX]
                or tly != prev[P_TLY]
                or buttons != prev[P_BTN]
            ):
                return -1
            continue
        frame_t[f] = q[i, 0] + q[i, 1] / 1_000_000
        btn = buttons
        if tool != 0:
            present_before = True
            prev[P_TOOL] = tool
            prev[P_X] = x
            prev[P_Y] = y
            prev[P_P] = p
            prev[P_TIP] = int(tip)
            prev[P_TLX] = tlx
            prev[P_TLY] = tly
            prev[P_BTN] = buttons
            inr = 1
        elif present_before:
            present_before = False  # the ended contact: the last one, tip and range off
            x, y, p, tlx, tly = prev[P_X], prev[P_Y], prev[P_P], prev[P_TLX], prev[P_TLY]
            tool, btn, tip = prev[P_TOOL], prev[P_BTN], False
            prev[P_TOOL] = 0
            inr = 0
        else:
            f += 1
            continue
        if x < ix0:
            x = ix0
        elif x > ix1:
            x = ix1
        if y < iy0:
            y = iy0
        elif y > iy1:
            y = iy1
        out_i[O_FRAME, n] = f
        out_i[O_CID, n] = 0
        out_i[O_TOOL, n] = tool
        out_i[O_TIP, n] = int(tip)
        out_i[O_IN, n] = inr
        out_i[O_BTN, n] = btn
        out_i[O_PNONE, n] = 0
        out_f[O_X, n] = (x - ix0) / rx / 1000
        out_f[O_Y, n] = (y - iy0) / ry / 1000
        pf = (p - p_off) * p_scale
        out_f[O_P, n] = 0.0 if pf < 0.0 else 1.0 if pf > 1.0 else pf
        v = (tlx - tx_off) * tx_scale
        out_f[O_TX, n] = tx_lo if v < tx_lo else tx_hi if v > tx_hi else v
        v = (tly - ty_off) * ty_scale
        out_f[O_TY, n] = ty_lo if v < ty_lo else ty_hi if v > ty_hi else v
        n += 1
        f += 1
    cfg[C_SEEN] = 1 if seen else 0
    res[0] = f
    res[1] = end
    return n


def multitouch(
    q: Array,
    h: Array,
    w: Array,
    known: Array,
    lo: Array,
    hi: Array,
    slots: Array,
    key_ok: Array,
    down: Array,
    button_codes: Array,
    button_bits: Array,
    cfg: Array,
    fcfg: Array,
    prev: Array,
    prev_n: Array,
    frame_t: Array,
    out_i: Array,
    out_f: Array,
    counts: Array,
    res: Array,
) -> int:  # pragma: no cover - compiled
    """Protocol B: a contact per slot with a tracking id that is not a palm.

    `slots` is int64[num_slots, 7]: tid, x, y, pressure, pressure-set, distance,
    tool type. `prev` holds the last frame's contacts (prev_n[0] of them)."""
    end = 0
    for i in range(h.shape[0] - 1, -1, -1):
        if h[i, 8] == 0 and h[i, 9] == 0:
            end = i + 1
            break
    if end == 0:
        return -4
    num = slots.shape[0]
    cur_slot = cfg[C_SLOT]
    if cur_slot < 0 or cur_slot >= num:
        return -3
    has_p = cfg[C_HAS_MT_P] != 0
    pen, finger = cfg[C_PEN_TOOL], cfg[C_FINGER_TOOL]
    x0, x1, y0, y1 = fcfg[F_X0], fcfg[F_X1], fcfg[F_Y0], fcfg[F_Y1]
    rx, ry = fcfg[F_RX], fcfg[F_RY]
    p_off, p_scale = fcfg[F_P_OFF], fcfg[F_P_SCALE]
    ix0, ix1, iy0, iy1 = int(x0), int(x1), int(y0), int(y1)
    buttons = 0
    for k in range(button_codes.shape[0]):
        if down[button_codes[k]]:
            buttons |= button_bits[k]
    now = prev.copy()  # this frame's contacts, built at each SYN_REPORT
    n = 0
    f = 0
    for i in range(-1, end):
        if i >= 0:
            typ = h[i, 8]
            code = h[i, 9]
            if typ == 3:
                value = w[i, 5]
                if code == ABS_MT_SLOT:
                    if value < 0 or value >= num:
                        return -3
                    cur_slot = value
                    continue
                if code >= N_ABS or not known[code]:
                    counts[K_UNKNOWN] += 1
                    continue
                if code < ABS_MT_SLOT:
                    continue  # the legacy single-touch axes of a multi-touch device
                if code == ABS_MT_TRACKING_ID:
                    old = slots[cur_slot, 0]
                    if value < 0:
                        slots[cur_slot, 0] = -1
                    elif value != old:
                        taken = False
                        for s in range(num):
                            if s != cur_slot and slots[s, 0] == value:
                                taken = True
                        if taken:
                            counts[K_REUSED] += 1
                            slots[cur_slot, 0] = -1
                        else:
                            if old >= 0:
                                counts[K_REPLACED] += 1
                            slots[cur_slot, 0] = value
                    continue
                if value < lo[code] or value > hi[code]:
                    counts[K_RANGE] += 1
                if code == ABS_MT_POSITION_X:
                    slots[cur_slot, 1] = value
                elif code == ABS_MT_POSITION_Y:
                    slots[cur_slot, 2] = value
                elif code == ABS_MT_PRESSURE:
                    slots[cur_slot, 3] = value
                    slots[cur_slot, 4] = 1
                elif code == ABS_MT_DISTANCE:
                    slots[cur_slot, 5] = value
                elif code == ABS_MT_TOOL_TYPE:
                    slots[cur_slot, 6] = value
                continue
            if typ == 1:
                code_ok = code < N_KEYS and key_ok[code] != 0
                value = w[i, 5]
                if not code_ok:
                    counts[K_UNKNOWN] += 1
                    continue
                if value == 0:
                    down[code] = 0
                elif value == 1 or value == 2:
                    down[code] = 1
                else:
                    counts[K_BADKEY] += 1
                    continue
                buttons = 0
                for k in range(button_codes.shape[0]):
                    if down[button_codes[k]]:
                        buttons |= button_bits[k]
                continue
            if typ != 0:
                continue
            if code == 3:
                return -2
            if code != 0:
                continue
        # a SYN_REPORT (or, at i == -1, the state the batch starts from)
        m = 0
        for s in range(num):
            tid = slots[s, 0]
            if tid < 0 or slots[s, 6] == MT_TOOL_PALM:
                continue
            now[m, P_TID] = tid
            now[m, P_SLOT] = s
            now[m, P_TOOL] = pen if slots[s, 6] == MT_TOOL_PEN else finger
            now[m, P_X] = slots[s, 1]
            now[m, P_Y] = slots[s, 2]
            pset = has_p and slots[s, 4] != 0
            now[m, P_P] = slots[s, 3] if pset else 0
            now[m, P_PNONE] = 0 if pset else 1
            now[m, P_TIP] = 1 if slots[s, 5] == 0 else 0
            now[m, P_BTN] = buttons
            m += 1
        if i < 0:
            if m != prev_n[0]:
                return -1
            for k in range(m):
                for j in range(N_PREV):
                    if j != P_TLX and j != P_TLY and now[k, j] != prev[k, j]:
                        return -1
            continue
        frame_t[f] = q[i, 0] + q[i, 1] / 1_000_000
        if n + prev_n[0] + m > out_i.shape[1]:
            return -5
        for two in range(2):  # the ended contacts (from prev), then the current ones
            src = prev if two == 0 else now
            count = prev_n[0] if two == 0 else m
            for k in range(count):
                tid = src[k, P_TID]
                if two == 0:
                    gone = True
                    for j in range(m):
                        if now[j, P_TID] == tid:
                            gone = False
                    if not gone:
                        continue
                x = src[k, P_X]
                y = src[k, P_Y]
                if x < ix0:
                    x = ix0
                elif x > ix1:
                    x = ix1
                if y < iy0:
                    y = iy0
                elif y > iy1:
                    y = iy1
                out_i[O_FRAME, n] = f
                out_i[O_CID, n] = tid
                out_i[O_TOOL, n] = src[k, P_TOOL]
                out_i[O_TIP, n] = src[k, P_TIP] if two == 1 else 0
                out_i[O_IN, n] = two
                out_i[O_BTN, n] = src[k, P_BTN]
                out_i[O_PNONE, n] = src[k, P_PNONE]
                out_f[O_X, n] = (x - ix0) / rx / 1000
                out_f[O_Y, n] = (y - iy0) / ry / 1000
                pf = (src[k, P_P] - p_off) * p_scale
                out_f[O_P, n] = 0.0 if pf < 0.0 else 1.0 if pf > 1.0 else pf
                out_f[O_TX, n] = 0.0
                out_f[O_TY, n] = 0.0
                n += 1
        for k in range(m):
            for j in range(N_PREV):
                prev[k, j] = now[k, j]
        prev_n[0] = m
        f += 1
    cfg[C_SLOT] = cur_slot
    res[0] = f
    res[1] = end
    return n
