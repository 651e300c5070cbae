"""One contact-step of the stick-slip model, written once.

Every piece of the model that changes a contact's state lives here as a free
function over one *row*: a flat sequence of floats holding the contact's
state, its parameters, its integrator settings and its counters, in the
layout below. ContactSim keeps its row in a Python list and calls these
functions as plain Python; the batch kernel (batch_kernel.py) compiles the
very same functions with numba and loops them over the rows of a 2-D array,
one row per contact. A change to the physics is made here, once, and both
follow it.

Why a row and not arguments: a CPython call costs per argument, and an
earlier shared slip step taking its 22 state and parameter values as
arguments made ContactSim 2-4 % slower. With the row, the hot calls take the
row plus the segment (h, touch velocity, end point): seven arguments, as the
old methods took with ``self``.

Why parameters are in the row: one batch can carry contacts on different
materials, and a contact that moves onto another material changes its row,
not its stepper.

The functions are written in the subset of Python numba compiles (no
dictionaries, no exceptions, floats and ints only; the row is indexed, never
sliced), and they never validate: ContactSim and BatchSim check every input
before it reaches a row.
"""

from __future__ import annotations

import math
from collections.abc import MutableSequence
from typing import Any

from stiction.sim.kernels import (
    NO_EVENT,
    ROUND_OFF,
    V_REST,
    band,
    first_entry,
    first_exit,
    gains_energy,
    propagator,
    rest_time,
)

Row = MutableSequence[float]
"""A list in ContactSim, a row of the (n, ROWS) float64 array in the batch kernel."""

# ------------------------------------------------------------------- modes
STICK, MOVING, RESTING, HOVER, UP = 0, 1, 2, 3, 4
"""Internal modes. MOVING and RESTING are both published as "slip": resting
in slip is the pen at rest while the spring pulls harder than static friction
holds (model.md: it moves again once the net force exceeds F_k)."""
PHASES = ("stick", "slip", "slip", "hover", "up")
"""The published phase of each mode."""

# ------------------------------------------------------------- integrators
EXACT, PROJECTION, EXPLICIT, SEMI_IMPLICIT, RK4 = 0, 1, 2, 3, 4
INTEGRATOR_CODES = {
    "exact": EXACT,
    "implicit-projection": PROJECTION,
    "explicit-euler": EXPLICIT,
    "semi-implicit-euler": SEMI_IMPLICIT,
    "rk4": RK4,
}

# -------------------------------------------------------------- row layout
# Ordered by use: a step without an event reads the first four cache lines
# (state, input path, parameters, the usual propagator) and nothing else.
# State.
PX, PY, VX, VY, UX, UY, DX, DY, MODE = range(9)
# Input path: the last tick reached (-inf before the first) and the last sample's time.
TICK, LAST_SAMPLE = 9, 10
PID = 11
"""Free for the owner of the row: which parameter set it holds (the scene
pipeline compares it to refresh rows when a scene or its parameters change)."""
# Parameters (model.md's table) and what is derived from them and the load.
K, M, C, W, MU_S, MU_K, G, CL, LOAD, RS2, FK = range(12, 23)
# Integrator settings.
HMAX, MAX_PIECES, INTEG, EVENTS = range(23, 27)
# Slip propagator for the usual piece length HMAX: c11 c12 c21 c22, then the
# half-step m21 m22 (kernels.propagator).
C0 = 27
# Two cached propagators for other piece lengths (a sample every 5 ms gives
# pieces of 5 ms and their round-off twins): length, then six coefficients.
HA, CA = 33, 34
HB, CB = 40, 41
NEXT = 47
"""Which cache slot the next miss overwrites (0 for A, 1 for B)."""
# Counters.
RELEASES, LAST_RELEASE, TRUNCATED, OVERFLOWS, REJECTED, CLAMPED = range(48, 54)
ROWS = 56
"""Seven cache lines of eight floats (two unused)."""

PARAM_FIRST, PARAM_END = K, NEXT + 1
"""Rows [PARAM_FIRST, PARAM_END) are a contact's parameters, integrator and
caches: set together by `set_params`, copied together between rows."""

SAFE_LO, SAFE_HI = 1e-290, 1e290
"""Lengths are sqrt(x*x + y*y) where the squares neither under- nor overflow
(within an ulp of math.hypot, a libm call that cost the compiled loop a
third of its time), math.hypot outside (a tiny velocity's squares underflow)."""

MAX_ZERO_EVENTS = 16
MIN_SEGMENT = 1e-9
"""Seconds. Samples closer than this are the same instant: the touch jumps.
Dividing a move by a few attoseconds of timestamp rounding would give a touch
velocity of 1e11 m/s and nothing but round-off in the step."""
BASE_PIECES = 1000
"""Pieces per segment beyond 64 ticks' worth (64 * substeps) before a long gap is
cut short: the touch is held still over such a gap and a moving pen has long
settled, so the rest is taken at rest rather than stalling a caller for
seconds (an hour-long gap with a frictionless material would be 360,000
pieces). Counted in TRUNCATED."""


# ------------------------------------------------------------------ set-up
def reset(r: Row) -> None:
    """A fresh contact: up, at the origin, load 1, counters zero, no parameters yet."""
    for i in range(ROWS):
        r[i] = 0.0
    r[DX] = 1.0
    r[MODE] = UP
    r[LOAD] = 1.0
    r[HA] = -1.0
    r[HB] = -1.0
    r[LAST_RELEASE] = math.nan
    r[TICK] = -math.inf
    r[LAST_SAMPLE] = -math.inf
    r[PID] = -1.0


def new_row() -> list[float]:
    """ContactSim's row: a Python list (fast to index from CPython)."""
    r = [0.0] * ROWS
    reset(r)
    return r


def set_params(
    r: Row,
    k: float,
    m: float,
    g: float,
    mu_s: float,
    mu_k: float,
    C_l: float,
    hmax: float,
    substeps: int,
    integ: int,
    events: bool,
) -> None:
    """Take a (validated) parameter set; the load gain and the state are kept."""
    r[K] = k
    r[M] = m
    r[G] = g
    r[MU_S] = mu_s
    r[MU_K] = mu_k
    r[CL] = C_l
    r[C] = 2.0 * math.sqrt(m * k)  # Params.c: critical damping
    w = math.sqrt(k / m)  # Params.w
    r[W] = w
    r[HMAX] = hmax
    r[MAX_PIECES] = BASE_PIECES + 64 * substeps
    r[INTEG] = integ
    r[EVENTS] = 1.0 if events else 0.0
    _fill_coeffs(r, C0, w, hmax)
    r[HA] = -1.0
    r[HB] = -1.0
    r[NEXT] = 0.0
    apply_load(r)


def apply_load(r: Row) -> None:
    """Static and kinetic friction at the current load: N = m g load_gain."""
    n = r[M] * r[G] * r[LOAD]
    fs = r[MU_S] * n
    r[FK] = r[MU_K] * n
    r[RS2] = (fs / r[K]) ** 2


def set_load(r: Row, load: float, t: float) -> None:
    """A new load gain; a stuck contact now outside its stick disc breaks away at t."""
    r[LOAD] = load
    apply_load(r)
    if r[MODE] == STICK and _stretch2(r) > r[RS2]:
        _release(r, t)
        rest_decide(r, 0.0, 0.0, True)


def _fill_coeffs(r: Row, at: int, w: float, h: float) -> None:
    c11, c12, c21, c22 = propagator(w, h)
    half = propagator(w, 0.5 * h)
    r[at] = c11
    r[at + 1] = c12
    r[at + 2] = c21
    r[at + 3] = c22
    r[at + 4] = half[2]
    r[at + 5] = half[3]


def coeffs(r: Row, h: float) -> int:
    """Where in the row the propagator for a piece of length h starts."""
    h0 = r[HMAX]
    if abs(h - h0) <= 1e-12 * h0:
        return C0
    if h == r[HA]:
        return CA
    if h == r[HB]:
        return CB
    if r[NEXT] == 0.0:
        r[HA] = h
        r[NEXT] = 1.0
        _fill_coeffs(r, CA, r[W], h)
        return CA
    r[HB] = h
    r[NEXT] = 0.0
    _fill_coeffs(r, CB, r[W], h)
    return CB


# ----------------------------------------------------------------- samples
def sample(
    r: Row, st: float, x: float, y: float, tip: bool, in_range: bool, t: float, cur: float
) -> float:
    """One input sample on the way to tick t; returns the time the path has reached.

    A non-finite or out-of-order sample is counted (REJECTED) and changes
    nothing; one stamped after the tick (or before the path's current time)
    is taken at the nearest allowed time and counted (CLAMPED).
    """
    if not (math.isfinite(st) and math.isfinite(x) and math.isfinite(y)):
        r[REJECTED] += 1.0
        return cur
    if st < r[LAST_SAMPLE]:
        r[REJECTED] += 1.0
        return cur
    r[LAST_SAMPLE] = st
    ts = st
    if ts > t:
        ts = t
        r[CLAMPED] += 1.0
    elif ts < cur:
        ts = cur
        r[CLAMPED] += 1.0
    take(r, x, y, tip, in_range, ts, cur)
    return ts


def advance_one(
    r: Row,
    st: Any,
    sx: Any,
    sy: Any,
    stip: Any,
    srange: Any,
    first: int,
    end: int,
    t: float,
    load: float,
) -> None:
    """ContactSim.advance over samples [first, end) of the arrays, for one row.

    The row's load gain changes first (a stuck contact outside its new stick
    disc breaks away at the previous tick), then every sample is followed,
    then the touch is held to t.
    """
    prev = r[TICK]
    if load != r[LOAD]:
        set_load(r, load, prev if prev > -math.inf else t)
    cur = prev
    for k in range(first, end):
        cur = sample(r, st[k], sx[k], sy[k], stip[k], srange[k], t, cur)
    hold(r, t, cur)
    r[TICK] = t


def take(r: Row, x: float, y: float, tip: bool, in_range: bool, ts: float, cur: float) -> None:
    """Follow the touch path from time cur to a (checked) sample at ts >= cur."""
    mode = r[MODE]
    if mode <= RESTING:
        if tip:
            h = ts - cur
            if h > MIN_SEGMENT:
                run(r, h, (x - r[UX]) / h, (y - r[UY]) / h, x, y, ts)
            else:
                jump(r, x, y, ts)
        else:
            # The contact ends at this sample; until then the touch is held
            # where it was last seen touching (a lift-off sample's position
            # may already be far away, or zero on some devices).
            if ts > cur:
                run(r, ts - cur, 0.0, 0.0, r[UX], r[UY], ts)
            lift(r, x, y, in_range)
    elif tip:
        r[UX] = r[PX] = x
        r[UY] = r[PY] = y
        r[VX] = r[VY] = 0.0
        r[MODE] = STICK
    else:
        lift(r, x, y, in_range)


def hold(r: Row, t: float, cur: float) -> None:
    """No (usable) sample up to tick t: the touch is held where it was since cur."""
    if r[MODE] <= RESTING and t > cur:
        run(r, t - cur, 0.0, 0.0, r[UX], r[UY], t)


def lift(r: Row, x: float, y: float, in_range: bool) -> None:
    r[UX] = r[PX] = x
    r[UY] = r[PY] = y
    r[VX] = r[VY] = 0.0
    r[MODE] = HOVER if in_range else UP


def _delta(r: Row) -> float:
    """Round-off carried by the stretch u - p at these coordinates."""
    return ROUND_OFF * (abs(r[UX]) + abs(r[UY]) + abs(r[PX]) + abs(r[PY]))


def _stretch2(r: Row) -> float:
    sx = r[UX] - r[PX]
    sy = r[UY] - r[PY]
    return sx * sx + sy * sy


def _release(r: Row, t: float) -> None:
    r[RELEASES] += 1.0
    r[LAST_RELEASE] = t


def jump(r: Row, x: float, y: float, t: float) -> None:
    """A sample at the same instant as the path's end: the touch jumps."""
    r[UX] = x
    r[UY] = y
    mode = r[MODE]
    if mode == STICK:
        if _stretch2(r) > r[RS2]:
            _release(r, t)
            rest_decide(r, 0.0, 0.0, True)
    elif mode == RESTING:
        rest_decide(r, 0.0, 0.0, False)


def rest_decide(r: Row, udx: float, udy: float, from_stick: bool) -> None:
    """The pen is at rest: stick, move along the net force, or rest in slip."""
    r[VX] = r[VY] = 0.0
    sx = r[UX] - r[PX]
    sy = r[UY] - r[PY]
    if not from_stick and sx * sx + sy * sy <= r[RS2]:
        r[MODE] = STICK
        return
    k = r[K]
    c = r[C]
    nx = k * sx + c * udx
    ny = k * sy + c * udy
    n2 = nx * nx + ny * ny
    n = math.sqrt(n2) if SAFE_LO < n2 < SAFE_HI else math.hypot(nx, ny)
    if n > r[FK] and n > 0.0:
        r[DX] = nx / n
        r[DY] = ny / n
        r[MODE] = MOVING
    else:
        r[MODE] = RESTING


def _start_moving(r: Row, udx: float, udy: float) -> None:
    """The net force has just reached F_k: move along it (no re-test, which
    round-off at the crossing could fail and leave the pen resting forever)."""
    nx = r[K] * (r[UX] - r[PX]) + r[C] * udx
    ny = r[K] * (r[UY] - r[PY]) + r[C] * udy
    n = math.sqrt(nx * nx + ny * ny)
    if n > 0.0:
        r[DX] = nx / n
        r[DY] = ny / n
    r[VX] = r[VY] = 0.0
    r[MODE] = MOVING


# ------------------------------------------------------------ one segment
def run(r: Row, h: float, udx: float, udy: float, u1x: float, u1y: float, t_end: float) -> None:
    """Advance over h seconds with the touch moving at (udx, udy), ending at u1 at t_end."""
    events = r[EVENTS] != 0.0
    if events and r[MODE] == STICK:
        # The touch path is a straight segment and the stick disc convex:
        # ending inside it, the contact stays stuck all segment.
        sx = u1x - r[PX]
        sy = u1y - r[PY]
        if sx * sx + sy * sy <= r[RS2]:
            r[UX] = u1x
            r[UY] = u1y
            return
    left = h
    zero_events = 0
    pieces = 0
    max_pieces = r[MAX_PIECES]
    eps = 1e-13 * h
    while left > eps:
        mode = r[MODE]
        if mode == STICK:
            if not events:
                r[UX] = u1x
                r[UY] = u1y
                if _stretch2(r) > r[RS2]:
                    _release(r, t_end)
                    rest_decide(r, udx, udy, True)
                return
            rs2 = r[RS2]
            tb = first_exit(r[UX] - r[PX], r[UY] - r[PY], udx, udy, rs2, left, band(rs2, _delta(r)))
            if tb == NO_EVENT:
                break
            r[UX] += udx * tb
            r[UY] += udy * tb
            left -= tb
            _release(r, t_end - left)
            rest_decide(r, udx, udy, True)
            consumed = tb
        elif mode == RESTING:
            if not events:
                r[UX] = u1x
                r[UY] = u1y
                rest_decide(r, udx, udy, False)
                return
            k = r[K]
            c = r[C]
            sx = r[UX] - r[PX]
            sy = r[UY] - r[PY]
            delta = _delta(r)
            rs2 = r[RS2]
            fk2 = r[FK] * r[FK]
            ts = first_entry(sx, sy, udx, udy, rs2, left, band(rs2, delta))
            tm = first_exit(
                k * sx + c * udx,
                k * sy + c * udy,
                k * udx,
                k * udy,
                fk2,
                left,
                band(fk2, k * delta),
            )
            tau = min(ts, tm)
            if tau == NO_EVENT:
                break
            r[UX] += udx * tau
            r[UY] += udy * tau
            left -= tau
            consumed = tau
            if ts <= tau:
                r[MODE] = STICK
            else:
                _start_moving(r, udx, udy)
        else:
            pieces += 1
            if pieces > max_pieces:
                r[TRUNCATED] += 1.0
                r[UX] = u1x
                r[UY] = u1y
                rest_decide(r, udx, udy, False)
                return
            hmax = r[HMAX]
            if left <= hmax:
                piece = left  # what ceil(left / hmax * (1 - 1e-12)) == 1 gives
            else:
                n = math.ceil(left / hmax * (1.0 - 1e-12))
                piece = left / n if n > 1 else left
            consumed, event = slip_piece(r, piece, udx, udy)
            left -= consumed
            if event:
                rest_decide(r, udx, udy, False)
        if consumed <= eps:
            zero_events += 1
            if zero_events > MAX_ZERO_EVENTS:
                # Should not happen; if it does, end the step in a state
                # that is at least consistent (phase matching the tension).
                r[OVERFLOWS] += 1.0
                r[UX] = u1x
                r[UY] = u1y
                rest_decide(r, udx, udy, False)
                return
    r[UX] = u1x
    r[UY] = u1y


def slip_piece(r: Row, h: float, udx: float, udy: float) -> tuple[float, bool]:
    """One piece of slip with the row's integrator: (time used, came to rest)."""
    integ = r[INTEG]
    if integ == EXACT:
        return piece_exact(r, h, udx, udy)
    if integ == PROJECTION:
        return piece_projection(r, h, udx, udy)
    return piece_explicit(r, h, udx, udy)


# -------------------------------------------------------------- integrators
def piece_exact(r: Row, h: float, udx: float, udy: float) -> tuple[float, bool]:
    """Closed-form slip over h, the friction direction frozen at its implicit mid-step value."""
    at = coeffs(r, h)
    c11 = r[at]
    c12 = r[at + 1]
    c21 = r[at + 2]
    c22 = r[at + 3]
    m21 = r[at + 4]
    m22 = r[at + 5]
    vx = r[VX]
    vy = r[VY]
    sp2 = vx * vx + vy * vy
    sp = math.sqrt(sp2) if SAFE_LO < sp2 < SAFE_HI else math.hypot(vx, vy)
    if sp > 0.0:
        d0x = vx / sp
        d0y = vy / sp
    else:
        d0x = r[DX]
        d0y = r[DY]
    k = r[K]
    q = r[FK] / k
    ux0 = r[UX]
    uy0 = r[UY]
    px0 = r[PX]
    py0 = r[PY]
    ex = px0 - ux0
    ey = py0 - uy0
    ydx = vx - udx
    ydy = vy - udy
    # Friction direction: that of the velocity at mid-step, taken implicitly.
    # With y0 = e + q d the mid-step velocity is affine in d,
    # v_mid(d) = A - beta d (beta > 0), where A is the frictionless
    # mid-step velocity; asking friction to oppose v_mid gives d = A/|A|
    # exactly. Second order in the turning of the direction, and stable
    # where friction dominates the pen's momentum (an explicit choice of d
    # overshoots sideways there and grows). On a straight stroke A lies on
    # the line, so 1-D stays exact.
    vmx = udx + m21 * ex + m22 * ydx
    vmy = udy + m21 * ey + m22 * ydy
    vmd = vmx * d0x + vmy * d0y
    nm2 = vmx * vmx + vmy * vmy
    nm = math.sqrt(nm2) if SAFE_LO < nm2 < SAFE_HI else math.hypot(vmx, vmy)
    if vmd > 0.0 and nm > 0.0:
        dx = vmx / nm
        dy = vmy / nm
    else:
        dx = d0x
        dy = d0y
    y0x = ex + q * dx
    y0y = ey + q * dy
    vnx = udx + c21 * y0x + c22 * ydx
    vny = udy + c21 * y0y + c22 * ydy
    f_h = vnx * d0x + vny * d0y
    g0 = udx * d0x + udy * d0y
    a = ydx * d0x + ydy * d0y
    w = r[W]
    b = w * ((ydx + w * y0x) * d0x + (ydy + w * y0y) * d0y)
    events = r[EVENTS] != 0.0
    if f_h > 0.0 and (
        not events or (g0 + a > 0.0 and not (b + w * a > 0.0 and w * b * h > b + w * a))
    ):
        # Positive at both ends and no interior minimum (f' changes sign
        # at most once, from - to + only where f'(0) < 0 < f'(h)).
        tau = NO_EVENT
    elif not events:
        tau = h
    else:
        tau = rest_time(g0, a, b, w, h, f_h)
    held = udx == 0.0 and udy == 0.0
    if tau == NO_EVENT:
        ux = ux0 + udx * h
        uy = uy0 + udy * h
        px = ux - q * dx + c11 * y0x + c12 * ydx
        py = uy - q * dy + c11 * y0y + c12 * ydy
        if held and gains_energy(ux0, uy0, px0, py0, vx, vy, px, py, vnx, vny, k, r[M]):
            # Touch held: the true motion only loses energy. In 2-D with
            # friction close to the spring force the frozen direction can
            # do a little positive work; there the pen is all but stopped,
            # so it comes to rest here (never on a straight stroke).
            r[VX] = r[VY] = 0.0
            return 0.0, True
        r[PX] = px
        r[PY] = py
        r[UX] = ux
        r[UY] = uy
        r[DX] = dx
        r[DY] = dy
        n2 = vnx * vnx + vny * vny
        if n2 < V_REST * V_REST and n2 < sp2:
            r[VX] = r[VY] = 0.0
            return h, True
        r[VX] = vnx
        r[VY] = vny
        return h, False
    if tau == h:
        e11 = c11
        e12 = c12
    elif tau > 0.0:
        e11, e12, _, _ = propagator(w, tau)
    else:
        e11 = 1.0
        e12 = 0.0
    ux = ux0 + udx * tau
    uy = uy0 + udy * tau
    px = ux - q * dx + e11 * y0x + e12 * ydx
    py = uy - q * dy + e11 * y0y + e12 * ydy
    if held and gains_energy(ux0, uy0, px0, py0, vx, vy, px, py, 0.0, 0.0, k, r[M]):
        r[VX] = r[VY] = 0.0  # as above: at rest where it is
        return 0.0, True
    r[PX] = px
    r[PY] = py
    r[UX] = ux
    r[UY] = uy
    r[VX] = r[VY] = 0.0
    return tau, True


def _accel(
    r: Row,
    px: float,
    py: float,
    vx: float,
    vy: float,
    ux: float,
    uy: float,
    udx: float,
    udy: float,
    dx: float,
    dy: float,
) -> tuple[float, float]:
    k = r[K]
    c = r[C]
    fk = r[FK]
    m = r[M]
    return (
        (k * (ux - px) + c * (udx - vx) - fk * dx) / m,
        (k * (uy - py) + c * (udy - vy) - fk * dy) / m,
    )


def step_fixed(
    r: Row, h: float, udx: float, udy: float, dx: float, dy: float
) -> tuple[float, float, float, float]:
    """One step of the fixed-step integrators from the row's state (no mutation)."""
    px = r[PX]
    py = r[PY]
    vx = r[VX]
    vy = r[VY]
    ux = r[UX]
    uy = r[UY]
    if r[INTEG] == RK4:
        h2 = 0.5 * h
        a1x, a1y = _accel(r, px, py, vx, vy, ux, uy, udx, udy, dx, dy)
        p2x, p2y, v2x, v2y = px + h2 * vx, py + h2 * vy, vx + h2 * a1x, vy + h2 * a1y
        um_x, um_y = ux + udx * h2, uy + udy * h2
        a2x, a2y = _accel(r, p2x, p2y, v2x, v2y, um_x, um_y, udx, udy, dx, dy)
        p3x, p3y, v3x, v3y = px + h2 * v2x, py + h2 * v2y, vx + h2 * a2x, vy + h2 * a2y
        a3x, a3y = _accel(r, p3x, p3y, v3x, v3y, um_x, um_y, udx, udy, dx, dy)
        p4x, p4y, v4x, v4y = px + h * v3x, py + h * v3y, vx + h * a3x, vy + h * a3y
        a4x, a4y = _accel(r, p4x, p4y, v4x, v4y, ux + udx * h, uy + udy * h, udx, udy, dx, dy)
        h6 = h / 6.0
        return (
            px + h6 * (vx + 2.0 * v2x + 2.0 * v3x + v4x),
            py + h6 * (vy + 2.0 * v2y + 2.0 * v3y + v4y),
            vx + h6 * (a1x + 2.0 * a2x + 2.0 * a3x + a4x),
            vy + h6 * (a1y + 2.0 * a2y + 2.0 * a3y + a4y),
        )
    ax, ay = _accel(r, px, py, vx, vy, ux, uy, udx, udy, dx, dy)
    if r[INTEG] == SEMI_IMPLICIT:
        nvx = vx + h * ax
        nvy = vy + h * ay
        return px + h * nvx, py + h * nvy, nvx, nvy
    return px + h * vx, py + h * vy, vx + h * ax, vy + h * ay


def piece_explicit(r: Row, h: float, udx: float, udy: float) -> tuple[float, bool]:
    """Explicit Euler, semi-implicit Euler or RK4 over h; rest found by bisection with events."""
    vx = r[VX]
    vy = r[VY]
    sp2 = vx * vx + vy * vy
    sp = math.sqrt(sp2) if SAFE_LO < sp2 < SAFE_HI else math.hypot(vx, vy)
    if sp > 0.0:
        dx = vx / sp
        dy = vy / sp
    else:
        dx = r[DX]
        dy = r[DY]
    px, py, nvx, nvy = step_fixed(r, h, udx, udy, dx, dy)
    tau = h
    event = nvx * dx + nvy * dy <= 0.0
    if event and r[EVENTS] != 0.0:
        lo = 0.0
        hi = h
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            qx, qy, qvx, qvy = step_fixed(r, mid, udx, udy, dx, dy)
            if qvx * dx + qvy * dy > 0.0:
                lo = mid
            else:
                hi = mid
                px = qx
                py = qy
            if hi - lo <= 4e-16 * hi:
                break
        tau = hi
    r[PX] = px
    r[PY] = py
    r[UX] += udx * tau
    r[UY] += udy * tau
    r[DX] = dx
    r[DY] = dy
    n2 = nvx * nvx + nvy * nvy
    if event or (n2 < V_REST * V_REST and n2 < sp2):
        r[VX] = r[VY] = 0.0
        return tau, True
    r[VX] = nvx
    r[VY] = nvy
    return tau, False


def piece_projection(r: Row, h: float, udx: float, udy: float) -> tuple[float, bool]:
    """Moreau-style implicit Euler: the friction cone decides v directly."""
    k = r[K]
    c = r[C]
    m = r[M]
    vx = r[VX]
    vy = r[VY]
    ux = r[UX] + udx * h
    uy = r[UY] + udy * h
    rx = m * vx + h * k * (ux - r[PX]) + h * c * udx
    ry = m * vy + h * k * (uy - r[PY]) + h * c * udy
    rn2 = rx * rx + ry * ry
    rn = math.sqrt(rn2) if SAFE_LO < rn2 < SAFE_HI else math.hypot(rx, ry)
    hf = h * r[FK]
    r[UX] = ux
    r[UY] = uy
    if rn <= hf:
        r[VX] = r[VY] = 0.0
        return h, True
    s = (rn - hf) / ((m + h * c + h * h * k) * rn)
    nvx = s * rx
    nvy = s * ry
    r[PX] += h * nvx
    r[PY] += h * nvy
    r[DX] = rx / rn
    r[DY] = ry / rn
    n2 = nvx * nvx + nvy * nvy
    sp2 = vx * vx + vy * vy
    if (sp2 > 0.0 and nvx * vx + nvy * vy <= 0.0) or (n2 < V_REST * V_REST and n2 < sp2):
        r[VX] = r[VY] = 0.0
        return h, True
    r[VX] = nvx
    r[VY] = nvy
    return h, False


# ------------------------------------------------------------------- batch
def advance_rows(
    S: Any,
    xs: Any,
    ys: Any,
    tips: Any,
    in_range: Any,
    t: float,
    prev: float,
) -> int:
    """One tick for every row of S: each takes its sample (xs[i], ys[i]) stamped at t.

    prev is the previous tick (-inf before the first). A non-finite sample
    holds the touch. Returns the number of rejected samples. The batch
    kernel compiles this loop; without numba it runs as it stands.
    """
    rejected = 0
    for i in range(S.shape[0]):
        r = S[i]
        x = xs[i]
        y = ys[i]
        if math.isfinite(x) and math.isfinite(y):
            take(r, x, y, tips[i], in_range[i], t, prev)
        else:
            rejected += 1
            hold(r, t, prev)
    return rejected


def set_loads(S: Any, loads: Any, t: float) -> None:
    """Each row takes its load gain (only rows whose gain changed do any work)."""
    for i in range(S.shape[0]):
        r = S[i]
        if loads[i] != r[LOAD]:
            set_load(r, loads[i], t)


def take_params(r: Row, src: Row) -> None:
    """Row r takes the parameters (and PID) of row src, keeping its load gain."""
    for f in range(PARAM_FIRST, PARAM_END):
        if f != LOAD:
            r[f] = src[f]
    r[PID] = src[PID]
    apply_load(r)


def touch_down(r: Row, x: float, y: float, t: float) -> None:
    """A fresh row touches down at (x, y) at time t, as if its previous tick were t."""
    sample(r, t, x, y, True, True, t, -math.inf)
    r[TICK] = t


def copy_params(S: Any, rows: Any, src: Any) -> None:
    """Rows `rows` of S take the parameters (and PID) of row `src`, keeping their load gain."""
    for j in range(rows.shape[0]):
        take_params(S[rows[j]], src)
