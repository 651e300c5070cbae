"""The scene pipeline's batch tick: one loop over a device's contacts, compiled with numba.

`Pipeline.step_arrays` calls `tick` once per device and tick. The loop does,
per contact, what `NaivePipeline._advance` does per Track -- the material
under the pen, entering and leaving friction, the glide back, the wire
fields -- but over arrays and rows, with the simulator's step called as
step.advance_one on the contact's row. Compiled (RowStepper.compile) it
costs a few dozen nanoseconds per contact beside the step itself;
without numba it runs as plain Python.

Written in the subset numba compiles: arrays, floats and ints only. The
geometry tests repeat stiction.scene.model's comparisons operation for
operation, so a point on an edge falls on the same side.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stiction.sim import step

# Per-slot columns of L (what the pipeline remembers about a contact between ticks).
LX, LY, LT, LTIP, LRANGE, LPRESS, LPHASE, LHASSIM, LMAT = range(9)
LCOLS = 9
# Output columns of O, one row per live contact in id order.
(OPHASE, OTX, OTY, OPX, OPY, OTPX, OTPY, OPPX, OPPY, OTEN, OMAT, OSLEN, OSDX, OSDY) = range(14)
OPRESS, OLOAD = 14, 15
OCOLS = 16
# cfg: friction, string, pressure, number of regions, outside material, number of materials.
CFRICTION, CSTRING, CPRESSURE, CNREG, COUTSIDE, CNMAT = range(6)
RECT, CIRCLE, POLYGON = 0, 1, 2
STICK_C, SLIP_C, HOVER_C, UP_C = 0, 1, 2, 3
SETTLE_DISTANCE_M = 1e-6  # stiction.scene.pipeline.SETTLE_DISTANCE_M


def _contains(k: int, gi: Any, gf: Any, pts: Any, px: float, py: float) -> bool:
    kind = gi[k, 0]
    if kind == RECT:
        x, y, w, h = gf[k, 0], gf[k, 1], gf[k, 2], gf[k, 3]
        return bool(x <= px <= x + w and y <= py <= y + h)
    if kind == CIRCLE:
        cx, cy, r = gf[k, 0], gf[k, 1], gf[k, 2]
        return bool((px - cx) ** 2 + (py - cy) ** 2 <= r * r)
    x0, y0, x1, y1 = gf[k, 0], gf[k, 1], gf[k, 2], gf[k, 3]
    if px < x0 or px > x1 or py < y0 or py > y1:
        return False
    inside = False
    first = gi[k, 2]
    end = gi[k, 3]
    j = end - 1
    for i in range(first, end):
        xi, yi = pts[i, 0], pts[i, 1]
        xj, yj = pts[j, 0], pts[j, 1]
        if (yi > py) != (yj > py) and px < (xj - xi) * (py - yi) / (yj - yi) + xi:
            inside = not inside
        j = i
    return inside


def material_at(gi: Any, gf: Any, pts: Any, cfg: Any, px: float, py: float) -> int:
    """Scene.material_at: the topmost (last listed) region containing the point wins."""
    for k in range(cfg[CNREG] - 1, -1, -1):
        if _contains(k, gi, gf, pts, px, py):
            return int(gi[k, 1])
    return int(cfg[COUTSIDE])


def scratch_size(samples: int, contacts: int) -> int:
    """How long each row of `tick`'s scratch arrays must be."""
    return max(samples, contacts + 1)


def _gain(pl: Any, p: float) -> float:
    """PressureLoad.gain; NaN (no pressure) and non-finite values give 1.0."""
    if not math.isfinite(p):
        return 1.0
    q = min(max(p, 0.0), 1.0)
    return float(pl[0] + (pl[1] - pl[0]) * q ** pl[2])


def tick(
    S: Any,
    L: Any,
    order_ids: Any,
    order_slots: Any,
    pos_of: Any,
    c: Any,
    st: Any,
    sx: Any,
    sy: Any,
    stip: Any,
    srange: Any,
    sp: Any,
    table: Any,
    gi: Any,
    gf: Any,
    pts: Any,
    cfg: Any,
    aff: Any,
    pl: Any,
    t: float,
    prev_t: float,
    out: Any,
    iw: Any,
    fw: Any,
    bw: Any,
) -> int:
    """Advance every live contact (order_ids, ascending) to t; fill out[j] for contact j.

    pos_of[id] is the position of contact `id` in order_ids (-1: none) for the
    ids below pos_of's length; larger (or negative) ids are searched for.
    iw (3 rows of int64), fw (4 rows of float64) and bw (2 rows of bool),
    each at least scratch_size(samples, contacts) long, are the caller's
    scratch space: the loop allocates nothing, so it is compiled without
    numba's reference counting (see Pipeline), which cost it more than its
    arithmetic. On return iw[2, n] holds how many contacts ended (phase
    up) at this tick, so that the caller looks for them only when some did.

    Returns the number of contacts, or -1 (having changed nothing) when a
    sample names a contact that has no slot yet: the caller adds it and
    calls again; -2 when `out` has fewer rows than there are contacts, -3
    when the scratch space is too short.
    """
    n = order_ids.shape[0]
    if out.shape[0] < n:
        return -2  # no room for every contact's output: refuse rather than write past it
    m = c.shape[0]
    need = scratch_size(m, n)
    if iw.shape[1] < need or fw.shape[1] < need or bw.shape[1] < need:
        return -3
    sj = iw[0]
    dense = pos_of.shape[0]
    for k in range(m):
        ck = c[k]
        if 0 <= ck < dense:
            j = pos_of[ck]
            if j < 0:
                return -1
        else:
            j = np.searchsorted(order_ids, ck)
            if j >= n or order_ids[j] != ck:
                return -1
        sj[k] = j
    # Each contact's samples together, in time order (a counting sort).
    fill = iw[1]
    for j in range(n + 1):
        fill[j] = 0
    for k in range(m):
        fill[sj[k] + 1] += 1
    for j in range(n):
        fill[j + 1] += fill[j]
    firsts = iw[2]
    for j in range(n):
        firsts[j] = fill[j]
    gt = fw[0]
    gx = fw[1]
    gy = fw[2]
    gp = fw[3]
    gtip = bw[0]
    grange = bw[1]
    for k in range(m):
        j = sj[k]
        q = fill[j]
        fill[j] = q + 1
        gt[q] = st[k]
        gx[q] = sx[k]
        gy[q] = sy[k]
        gp[q] = sp[k]
        gtip[q] = stip[k]
        grange[q] = srange[k]
    ax, bx, cx, ay, by, cy = aff[0], aff[1], aff[2], aff[3], aff[4], aff[5]
    friction = cfg[CFRICTION] != 0
    string = cfg[CSTRING] != 0
    pressure = cfg[CPRESSURE] != 0
    nmat = cfg[CNMAT]
    ended = 0
    for j in range(n):
        i = order_slots[j]
        lr = L[i]
        touching = lr[LPHASE] <= SLIP_C
        hx = lr[LX]
        hy = lr[LY]
        htip = lr[LTIP] != 0.0
        first = firsts[j]
        end = fill[j]
        if end > first:
            q = end - 1
            lr[LX] = gx[q]
            lr[LY] = gy[q]
            lr[LT] = gt[q]
            lr[LTIP] = 1.0 if gtip[q] else 0.0
            lr[LRANGE] = 1.0 if grange[q] else 0.0
            lr[LPRESS] = gp[q]
        lx = lr[LX]
        ly = lr[LY]
        if lr[LRANGE] == 0.0:
            phase = UP_C
        elif lr[LTIP] != 0.0:
            phase = SLIP_C
        else:
            phase = HOVER_C
        tx = lx
        ty = ly
        px = lx
        py = ly
        ten = 0.0
        mat_out = -1
        slen = 0.0
        sdx = 0.0
        sdy = 0.0
        load = _gain(pl, lr[LPRESS]) if pressure else 1.0
        if not friction:
            if cfg[CNREG] == 0:
                mat_out = int(cfg[COUTSIDE])
            else:
                mat_out = material_at(
                    gi, gf, pts, cfg, ax * lx + bx * ly + cx, ay * lx + by * ly + cy
                )
        else:
            has_sim = lr[LHASSIM] != 0.0
            r = S[i]
            mx = lx
            my = ly
            if touching and has_sim:
                mx = r[step.PX]
                my = r[step.PY]
            mat = material_at(gi, gf, pts, cfg, ax * mx + bx * my + cx, ay * mx + by * my + cy)
            old = int(lr[LMAT])
            fric = mat >= 0
            glide = (not fric) and has_sim and touching and old >= 0
            if fric and not has_sim:
                step.reset(r)
                r[step.LOAD] = load
                step.take_params(r, table[mat])
                if touching and htip:
                    # Entering friction mid-stroke: the contact starts where
                    # the touch was held at the previous tick.
                    step.touch_down(r, hx, hy, prev_t)
            want = mat if fric else (nmat + old if glide else -1)
            sim_after = False
            if want >= 0:
                if r[step.PID] != table[want, step.PID]:
                    # Another material, an earlier scene, or changed parameters.
                    step.take_params(r, table[want])
                step.advance_one(r, gt, gx, gy, gtip, grange, first, end, t, load)
                mode = int(r[step.MODE])
                on = mode < step.HOVER
                ux = r[step.UX]
                uy = r[step.UY]
                rx = r[step.PX] if on else ux
                ry = r[step.PY] if on else uy
                ex = ux - rx
                ey = uy - ry
                d = math.sqrt(ex * ex + ey * ey)
                tension = r[step.K] * d if on else 0.0
                if (not glide) or (on and not (math.hypot(ex, ey) < SETTLE_DISTANCE_M)):
                    sim_after = True
                    if mode == step.STICK:
                        phase = STICK_C
                    elif on:
                        phase = SLIP_C
                    elif mode == step.HOVER:
                        phase = HOVER_C
                    else:
                        phase = UP_C
                    tx = ux
                    ty = uy
                    px = rx
                    py = ry
                    ten = tension
                    mat_out = -1 if glide else mat
                    if string and on and d > 0.0:
                        slen = r[step.CL] * math.sqrt(tension)
                        sdx = ex / d
                        sdy = ey / d
            lr[LHASSIM] = 1.0 if sim_after else 0.0
            lr[LMAT] = mat if fric else (old if sim_after else -1)
        lr[LPHASE] = phase
        if phase == UP_C:
            ended += 1
        o = out[j]
        o[OPHASE] = phase
        o[OTX] = tx
        o[OTY] = ty
        o[OPX] = px
        o[OPY] = py
        o[OTPX] = ax * tx + bx * ty + cx
        o[OTPY] = ay * tx + by * ty + cy
        o[OPPX] = ax * px + bx * py + cx
        o[OPPY] = ay * px + by * py + cy
        o[OTEN] = ten
        o[OMAT] = mat_out
        o[OSLEN] = slen
        o[OSDX] = sdx
        o[OSDY] = sdy
        o[OPRESS] = lr[LPRESS]
        o[OLOAD] = load
    firsts[n] = ended
    return int(n)


CALLEES = (_contains, material_at, scratch_size, _gain)
"""What `tick` calls besides step.py: registered with numba before it compiles `tick`."""
