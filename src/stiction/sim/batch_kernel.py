"""BatchSim's exact integrator with event location, compiled with numba.

The numpy form in batch.py needs about a hundred array passes per tick for
the contacts without an event and then loops, a few numpy calls per mode and
per event, over the contacts that have one; at 10,000 contacts that came to
200-360 ns per contact-step, most of it numpy call overhead on the small
event subsets. Here each contact takes ContactSim._run's own scalar steps
(same formulas, same order of operations), so the result equals ContactSim's
to round-off, and a contact-step without an event costs a few dozen
multiply-adds.

Imported lazily by batch.py; numba compiles on first use (cached on disk).
Without numba, BatchSim uses its numpy path, which gives the same results.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba  # type: ignore[import-untyped]
import numpy as np
import numpy.typing as npt
from numba.extending import register_jitable  # type: ignore[import-untyped]

from stiction.sim import kernels
from stiction.sim.kernels import ROUND_OFF, V_REST

_Fn = TypeVar("_Fn", bound=Callable[..., Any])

STICK, MOVING, RESTING, HOVER, UP = 0, 1, 2, 3, 4
PX, PY, VX, VY, UX, UY, DX, DY, UDX, UDY = range(10)
FS2, FK = 11, 12
_MAX_ZERO_EVENTS = 16
INF = math.inf


def _jit(fn: _Fn) -> _Fn:
    return cast(_Fn, numba.njit(cache=True, nogil=True)(fn))


def _jit_inline(fn: _Fn) -> _Fn:
    return cast(_Fn, numba.njit(cache=True, nogil=True, inline="always")(fn))


@_jit_inline
def _hypot(x: float, y: float) -> float:
    """math.hypot to within an ulp: sqrt where the squares neither under- nor overflow."""
    s2 = x * x + y * y
    if 1e-290 < s2 < 1e290:
        return math.sqrt(s2)
    return math.hypot(x, y)


# The event finders are kernels.py's own functions, compiled here: one source
# for ContactSim and the batch loop. register_jitable lets the compiled
# rest_time call kernels' plain Python helpers.
register_jitable(kernels._f)
register_jitable(kernels._polish)
_band = _jit(kernels.band)
_propagator = _jit_inline(kernels.propagator)
_gains_energy = _jit_inline(kernels.gains_energy)
_first_exit = _jit(kernels.first_exit)
_first_entry = _jit(kernels.first_entry)
_rest_time = _jit(kernels.rest_time)


@_jit_inline
def _rest_decide(
    S: npt.NDArray[np.float64],
    i: int,
    udx: float,
    udy: float,
    from_stick: bool,
    k: float,
    c: float,
) -> int:
    """ContactSim._rest_decide for column i; returns the new mode."""
    S[VX, i] = 0.0
    S[VY, i] = 0.0
    sx = S[UX, i] - S[PX, i]
    sy = S[UY, i] - S[PY, i]
    if not from_stick and sx * sx + sy * sy <= S[FS2, i]:
        return STICK
    nx = k * sx + c * udx
    ny = k * sy + c * udy
    n = _hypot(nx, ny)
    if n > S[FK, i] and n > 0.0:
        S[DX, i] = nx / n
        S[DY, i] = ny / n
        return MOVING
    return RESTING


@_jit_inline
def _piece_exact(
    S: npt.NDArray[np.float64],
    i: int,
    h: float,
    udx: float,
    udy: float,
    cf: npt.NDArray[np.float64],
    k: float,
    m: float,
    w: float,
) -> tuple[float, bool]:
    """ContactSim._piece_exact (events on) for column i; cf = (c11, c12, c21, c22, m21, m22)."""
    c11, c12, c21, c22, m21, m22 = cf[0], cf[1], cf[2], cf[3], cf[4], cf[5]
    vx, vy = S[VX, i], S[VY, i]
    sp2 = vx * vx + vy * vy
    sp = _hypot(vx, vy)
    if sp > 0.0:
        d0x, d0y = vx / sp, vy / sp
    else:
        d0x, d0y = S[DX, i], S[DY, i]
    q = S[FK, i] / k
    ex = S[PX, i] - S[UX, i]
    ey = S[PY, i] - S[UY, i]
    ydx = vx - udx
    ydy = vy - udy
    vmx = udx + m21 * ex + m22 * ydx
    vmy = udy + m21 * ey + m22 * ydy
    vmd = vmx * d0x + vmy * d0y
    nm = _hypot(vmx, vmy)
    if vmd > 0.0 and nm > 0.0:
        dx, dy = vmx / nm, vmy / nm
    else:
        dx, dy = d0x, d0y
    y0x = ex + q * dx
    y0y = ey + q * dy
    vnx = udx + c21 * y0x + c22 * ydx
    vny = udy + c21 * y0y + c22 * ydy
    f_h = vnx * d0x + vny * d0y
    g0 = udx * d0x + udy * d0y
    a = ydx * d0x + ydy * d0y
    b = w * ((ydx + w * y0x) * d0x + (ydy + w * y0y) * d0y)
    if f_h > 0.0 and (g0 + a > 0.0 and not (b + w * a > 0.0 and w * b * h > b + w * a)):
        tau = INF
    else:
        tau = _rest_time(g0, a, b, w, h, f_h)
    held = udx == 0.0 and udy == 0.0
    if tau == INF:
        ux = S[UX, i] + udx * h
        uy = S[UY, i] + udy * h
        px = ux - q * dx + c11 * y0x + c12 * ydx
        py = uy - q * dy + c11 * y0y + c12 * ydy
        if held and _gains_energy(
            S[UX, i], S[UY, i], S[PX, i], S[PY, i], vx, vy, px, py, vnx, vny, k, m
        ):
            S[VX, i] = 0.0
            S[VY, i] = 0.0
            return 0.0, True
        S[PX, i] = px
        S[PY, i] = py
        S[UX, i] = ux
        S[UY, i] = uy
        S[DX, i] = dx
        S[DY, i] = dy
        n2 = vnx * vnx + vny * vny
        if n2 < V_REST * V_REST and n2 < sp2:
            S[VX, i] = 0.0
            S[VY, i] = 0.0
            return h, True
        S[VX, i] = vnx
        S[VY, i] = vny
        return h, False
    if tau == h:
        e11, e12 = c11, c12
    elif tau > 0.0:
        e11, e12, _, _ = _propagator(w, tau)
    else:
        e11, e12 = 1.0, 0.0
    ux = S[UX, i] + udx * tau
    uy = S[UY, i] + udy * tau
    px = ux - q * dx + e11 * y0x + e12 * ydx
    py = uy - q * dy + e11 * y0y + e12 * ydy
    if held and _gains_energy(
        S[UX, i], S[UY, i], S[PX, i], S[PY, i], vx, vy, px, py, 0.0, 0.0, k, m
    ):
        S[VX, i] = 0.0
        S[VY, i] = 0.0
        return 0.0, True
    S[PX, i] = px
    S[PY, i] = py
    S[UX, i] = ux
    S[UY, i] = uy
    S[VX, i] = 0.0
    S[VY, i] = 0.0
    return tau, True


@_jit_inline
def _segment(
    S: npt.NDArray[np.float64],
    i: int,
    md: int,
    u1x: float,
    u1y: float,
    h: float,
    k: float,
    m: float,
    c: float,
    w: float,
    hmax: float,
    c0: npt.NDArray[np.float64],
    max_pieces: int,
    cf: npt.NDArray[np.float64],
) -> tuple[int, int, int]:
    """ContactSim._run over h with the touch moving in a straight line to u1.

    Returns (new mode, truncated steps, event overflows).
    """
    eps = 1e-13 * h
    udx = (u1x - S[UX, i]) / h
    udy = (u1y - S[UY, i]) / h
    S[UDX, i] = udx
    S[UDY, i] = udy
    left = h
    zero_events = 0
    pieces = 0
    while left > eps:
        if md == STICK:
            ux, uy, px, py = S[UX, i], S[UY, i], S[PX, i], S[PY, i]
            rs2 = S[FS2, i]
            delta = ROUND_OFF * (abs(ux) + abs(uy) + abs(px) + abs(py))
            tb = _first_exit(ux - px, uy - py, udx, udy, rs2, left, _band(rs2, delta))
            if tb == INF:
                break
            S[UX, i] = ux + udx * tb
            S[UY, i] = uy + udy * tb
            left -= tb
            md = _rest_decide(S, i, udx, udy, True, k, c)
            consumed = tb
        elif md == RESTING:
            ux, uy, px, py = S[UX, i], S[UY, i], S[PX, i], S[PY, i]
            rs2 = S[FS2, i]
            fk = S[FK, i]
            sx = ux - px
            sy = uy - py
            delta = ROUND_OFF * (abs(ux) + abs(uy) + abs(px) + abs(py))
            fk2 = fk * fk
            ts = _first_entry(sx, sy, udx, udy, rs2, left, _band(rs2, delta))
            tm = _first_exit(
                k * sx + c * udx,
                k * sy + c * udy,
                k * udx,
                k * udy,
                fk2,
                left,
                _band(fk2, k * delta),
            )
            if ts == INF and tm == INF:
                break
            tau = min(ts, tm)
            S[UX, i] = ux + udx * tau
            S[UY, i] = uy + udy * tau
            left -= tau
            consumed = tau
            if ts != INF and ts <= tau:
                md = STICK
            else:
                # ContactSim._start_moving
                nx = k * (S[UX, i] - px) + c * udx
                ny = k * (S[UY, i] - py) + c * udy
                n = math.sqrt(nx * nx + ny * ny)
                if n > 0.0:
                    S[DX, i] = nx / n
                    S[DY, i] = ny / n
                S[VX, i] = 0.0
                S[VY, i] = 0.0
                md = MOVING
        else:
            pieces += 1
            if pieces > max_pieces:
                S[UX, i] = u1x
                S[UY, i] = u1y
                return _rest_decide(S, i, udx, udy, False, k, c), 1, 0
            if left <= hmax:
                piece = left  # what ceil(left / hmax * (1 - 1e-12)) == 1 gives
            else:
                npc = math.ceil(left / hmax * (1.0 - 1e-12))
                piece = left / npc if npc > 1 else left
            if abs(piece - hmax) <= 1e-12 * hmax:
                coef = c0
            else:
                half = _propagator(w, 0.5 * piece)
                cf[0], cf[1], cf[2], cf[3] = _propagator(w, piece)
                cf[4], cf[5] = half[2], half[3]
                coef = cf
            consumed, event = _piece_exact(S, i, piece, udx, udy, coef, k, m, w)
            left -= consumed
            if event:
                md = _rest_decide(S, i, udx, udy, False, k, c)
        if consumed <= eps:
            zero_events += 1
            if zero_events > _MAX_ZERO_EVENTS:
                S[UX, i] = u1x
                S[UY, i] = u1y
                return _rest_decide(S, i, udx, udy, False, k, c), 0, 1
    S[UX, i] = u1x
    S[UY, i] = u1y
    return md, 0, 0


@_jit
def advance_exact(
    S: npt.NDArray[np.float64],
    mode: npt.NDArray[np.int8],
    xs: npt.NDArray[np.float64],
    ys: npt.NDArray[np.float64],
    tips: npt.NDArray[np.bool_],
    in_range: npt.NDArray[np.bool_],
    step: bool,
    h: float,
    k: float,
    m: float,
    c: float,
    w: float,
    hmax: float,
    c0: npt.NDArray[np.float64],
    max_pieces: int,
) -> tuple[int, int, int]:
    """One tick of BatchSim.advance for every contact (exact, events on).

    Sample handling as BatchSim.advance: touch-down, lift-off, hover and up
    take the sample's position; a touching contact follows its sample over h
    (if step) or holds its touch when the sample is not finite. Returns
    (rejected samples, truncated steps, event overflows).
    """
    rejected = 0
    truncated = 0
    overflows = 0
    cf = np.empty(6)
    for i in range(S.shape[1]):
        x = xs[i]
        y = ys[i]
        ok = math.isfinite(x) and math.isfinite(y)
        md = int(mode[i])
        touching = md <= RESTING
        if not ok:
            rejected += 1
        elif touching != bool(tips[i]) or not touching:
            # lift-off, touch-down, or hover/up moving on
            S[PX, i] = x
            S[UX, i] = x
            S[PY, i] = y
            S[UY, i] = y
            S[VX, i] = 0.0
            S[VY, i] = 0.0
            if tips[i]:
                mode[i] = STICK
            else:
                mode[i] = HOVER if in_range[i] else UP
            continue
        if touching and step:
            if ok:
                u1x, u1y = x, y
            else:
                u1x, u1y = S[UX, i], S[UY, i]
            if md == STICK:
                # The touch path is a straight segment and the stick disc is
                # convex: ending inside it, the contact stays stuck all tick.
                sx = u1x - S[PX, i]
                sy = u1y - S[PY, i]
                if sx * sx + sy * sy <= S[FS2, i]:
                    S[UDX, i] = (u1x - S[UX, i]) / h
                    S[UDY, i] = (u1y - S[UY, i]) / h
                    S[UX, i] = u1x
                    S[UY, i] = u1y
                    continue
            md, tr, ov = _segment(S, i, md, u1x, u1y, h, k, m, c, w, hmax, c0, max_pieces, cf)
            truncated += tr
            overflows += ov
            mode[i] = md
    return rejected, truncated, overflows
