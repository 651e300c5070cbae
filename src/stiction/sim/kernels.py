"""Closed-form pieces shared by the one-contact and the batch simulator.

In slip, with the friction direction d frozen over a (sub)step and the touch u
moving at constant velocity ud, the stretch e = p - u obeys the critically
damped linear ODE  e'' + 2w e' + w^2 e = -w^2 (F_k/k) d.  Its solution is an
affine map of (e, e') whose coefficients depend only on w and the step h, so
they are computed once per step length and a tick without an event costs a
few multiply-adds. Events (break-away, coming to rest) are located on the
closed forms: the touch is linear in time, so the stick bound is a quadratic;
the velocity along a direction is g0 + (A - B tau) exp(-w tau), whose first
zero is bracketed analytically and polished by safeguarded Newton.
"""

from __future__ import annotations

import math

EXP_CUTOFF = 700.0
"""exp(-700) ~ 1e-304: beyond this the propagator is exactly zero, never a denormal."""
TINY = 1e-280
"""Coefficients below this are flushed to zero so that long runs never hit denormals."""

Coeffs = tuple[float, float, float, float]


NO_EVENT = math.inf
"""What the event finders return when nothing happens within the step: a
float rather than None, so that batch_kernel.py can compile these very
functions with numba (they are written in the subset numba compiles)."""


def propagator(w: float, h: float) -> Coeffs:
    """(c11, c12, c21, c22): y(h) = c11 y0 + c12 y0',  y'(h) = c21 y0 + c22 y0'."""
    wh = w * h
    if wh > EXP_CUTOFF:
        return (0.0, 0.0, 0.0, 0.0)
    e = math.exp(-wh)
    c = (e * (1.0 + wh), e * h, -e * w * w * h, e * (1.0 - wh))
    return (
        c[0] if abs(c[0]) >= TINY else 0.0,
        c[1] if abs(c[1]) >= TINY else 0.0,
        c[2] if abs(c[2]) >= TINY else 0.0,
        c[3] if abs(c[3]) >= TINY else 0.0,
    )


V_REST = 1e-12
"""m/s. With the touch held still a critically damped pen approaches its rest
point exponentially and never reaches v = 0 exactly; below this speed (a pixel
every few years) it counts as having come to rest. Without it a long still
hold would creep into denormal numbers."""


BOUNDARY = 1e-12
"""Relative band around a crossing radius counted as "on the boundary". There the
direction of motion decides: a stretch exactly at F_s/k moving outward has just
broken away, moving inward has just stuck. Without it, round-off at the crossing
point can make both "break away" and "stick again" true at once."""


ROUND_OFF = 1e-15
"""Relative round-off of an absolute coordinate after a few operations."""


def band(r2: float, delta: float) -> float:
    """Half-width of the boundary band of |a|^2 = r2 when |a| carries an error delta."""
    return BOUNDARY * r2 + delta * (2.0 * math.sqrt(r2) + delta)


def gains_energy(
    ux: float,
    uy: float,
    p0x: float,
    p0y: float,
    v0x: float,
    v0y: float,
    px: float,
    py: float,
    vx: float,
    vy: float,
    k: float,
    m: float,
) -> bool:
    """Would moving from (p0, v0) to (p, v) raise 0.5 m v^2 + 0.5 k s^2 (touch held at u)?"""
    sx0, sy0 = ux - p0x, uy - p0y
    sx1, sy1 = ux - px, uy - py
    s02 = sx0 * sx0 + sy0 * sy0
    e0 = m * (v0x * v0x + v0y * v0y) + k * s02
    e1 = m * (vx * vx + vy * vy) + k * (sx1 * sx1 + sy1 * sy1)
    # The stretch is a difference of absolute coordinates.
    d = ROUND_OFF * (abs(ux) + abs(uy) + abs(p0x) + abs(p0y))
    return e1 > e0 * (1.0 + 1e-12) + 2.0 * k * d * (2.0 * math.sqrt(s02) + d)


def first_exit(
    a0x: float, a0y: float, a1x: float, a1y: float, r2: float, hmax: float, tol: float
) -> float:
    """First tau in [0, hmax] where |a0 + a1 tau|^2 passes r2 going out, else NO_EVENT.

    tol (from `band`) is the band around r2 that counts as on the boundary.
    """
    c = a0x * a0x + a0y * a0y - r2
    b = 2.0 * (a0x * a1x + a0y * a1y)
    if c > tol or (c > -tol and b > 0.0):
        return 0.0
    a = a1x * a1x + a1y * a1y
    if a == 0.0:
        return NO_EVENT
    if c >= -tol:
        tau = -b / a  # on the boundary moving in: out again through the other root
    else:
        sq = math.sqrt(max(b * b - 4.0 * a * c, 0.0))
        # The non-negative root, in the form that does not cancel.
        tau = (-b + sq) / (2.0 * a) if b <= 0.0 else (2.0 * c) / (-b - sq)
    if tau > hmax:
        return NO_EVENT
    return max(tau, 0.0)


def first_entry(
    a0x: float, a0y: float, a1x: float, a1y: float, r2: float, hmax: float, tol: float
) -> float:
    """First tau in [0, hmax] where |a0 + a1 tau|^2 falls to r2 or below, else NO_EVENT."""
    c = a0x * a0x + a0y * a0y - r2
    b = 2.0 * (a0x * a1x + a0y * a1y)
    if c < -tol or (c <= tol and b < 0.0):
        return 0.0
    a = a1x * a1x + a1y * a1y
    if a == 0.0 or b >= 0.0 or c <= tol:
        return NO_EVENT
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        return NO_EVENT
    q = 0.5 * (-b + math.sqrt(disc))
    tau = c / q
    if tau > hmax:
        return NO_EVENT
    return tau


def rest_time(g0: float, a: float, b: float, w: float, h: float, f_h: float) -> float:
    """First tau in (0, h] where f(tau) = g0 + (a - b tau) exp(-w tau) <= 0, else NO_EVENT.

    f is the pen velocity along the direction it had at the start of the step;
    f(h) is passed in because the caller already has it. f' changes sign at
    most once, so f has at most two zeros and the bracket is found exactly.
    """
    f0 = g0 + a
    d0 = -(b + w * a)  # f'(0)
    tc = (1.0 / w + a / b) if b != 0.0 else -1.0  # where f' = 0
    interior = 0.0 < tc < h
    if f_h <= 0.0:
        if f0 > 0.0:
            lo, hi = 0.0, h
        elif d0 > 0.0 and interior and _f(g0, a, b, w, tc) > 0.0:
            lo, hi = tc, h
        else:
            return 0.0
    else:
        if f0 <= 0.0:
            # Starting from rest (f(0) = 0) along the net force: at the very
            # instant the net force reaches F_k the acceleration is zero and
            # round-off may make f'(0) a hair negative; moving forward at the
            # end of the step means it did start.
            return NO_EVENT
        if not (d0 < 0.0 and interior):
            return NO_EVENT
        if _f(g0, a, b, w, tc) > 0.0:
            return NO_EVENT
        lo, hi = 0.0, tc
    return _polish(g0, a, b, w, lo, hi)


def _f(g0: float, a: float, b: float, w: float, tau: float) -> float:
    return g0 + (a - b * tau) * math.exp(-w * tau)


def _polish(g0: float, a: float, b: float, w: float, lo: float, hi: float) -> float:
    """Safeguarded Newton inside [lo, hi] with f(lo) > 0 >= f(hi).

    Stops when the Newton step no longer moves tau (one-sided Newton never
    shrinks the bracket, so its width is not a usable stopping rule).
    """
    tau = 0.5 * (lo + hi)
    for _ in range(64):
        e = math.exp(-w * tau)
        f = g0 + (a - b * tau) * e
        if f > 0.0:
            lo = tau
        else:
            hi = tau
        fp = e * (w * b * tau - b - w * a)
        step = f / fp if fp != 0.0 else math.inf
        if abs(step) <= 4e-16 * tau + 1e-300:
            return tau
        nxt = tau - step
        if not lo < nxt < hi:
            nxt = 0.5 * (lo + hi)
            if nxt == lo or nxt == hi:  # noqa: SIM109 (numba compiles this form)
                return hi
        tau = nxt
    return tau
