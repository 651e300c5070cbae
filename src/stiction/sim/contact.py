"""One contact: the input path, touch-down/up, stick, slip and the integrators.

The daemon calls `ContactSim.advance` once per contact per tick, so this is
plain-float Python with the per-step constants precomputed: the closed-form
slip propagator for the usual step length is computed once per Params, and a
tick with no event is a handful of multiply-adds on locals.

Internally slip has two modes: moving (friction -F_k along the direction of
motion) and resting-in-slip (the pen is at rest but the spring pulls harder
than static friction holds; docs/design/model.md: it moves again once the net force
exceeds F_k, it sticks once T <= F_s). Both are published as phase "slip".
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from stiction.errors import ParamError
from stiction.sim import kernels
from stiction.sim.integrators import INTEGRATORS, check_substeps, checked_params, resolve
from stiction.sim.params import Params, check_tick
from stiction.sim.state import ContactState, Phase

STICK, MOVING, RESTING, HOVER, UP = 0, 1, 2, 3, 4
_PHASE: tuple[Phase, ...] = ("stick", "slip", "slip", "hover", "up")

V_REST = kernels.V_REST

_MAX_ZERO_EVENTS = 16
MIN_SEGMENT = 1e-9
"""Seconds. Samples closer than this are the same instant: the touch jumps.
Dividing a move by a few attoseconds of timestamp rounding would give a touch
velocity of 1e11 m/s and nothing but round-off in the step."""
_BASE_PIECES = 1000
"""Pieces per segment beyond 64 ticks' worth (64 * substeps) before a long gap is
cut short: the touch is held still over such a gap and a moving pen has long
settled, so the rest is taken at rest rather than stalling a caller for
seconds (an hour-long gap with a frictionless material would be 360,000
pieces). Counted in `truncated_steps`."""


class ContactSim:
    """The stick-slip state of one contact, advanced tick by tick."""

    def __init__(
        self,
        params: Params | None = None,
        integrator: str = "default",
        substeps: int = 1,
        events: bool | None = None,
        string: bool = True,
    ) -> None:
        self.integrator = resolve(integrator)
        self.substeps = check_substeps(substeps)
        self.events = (self.integrator == "exact") if events is None else bool(events)
        self.string = bool(string)
        self.rejected_samples = 0
        self.clamped_samples = 0
        self.event_overflows = 0
        self.releases = 0
        self.truncated_steps = 0
        self.last_release = math.nan
        """Time of the latest break-away (stick -> slip), located inside the step
        when events are on, else the end of the step that detected it."""
        self._t: float | None = None
        self._last_sample_t = -math.inf
        self._mode = UP
        self._px = self._py = self._vx = self._vy = 0.0
        self._ux = self._uy = 0.0
        self._dx, self._dy = 1.0, 0.0
        self._load = 1.0
        self._cache: dict[float, tuple[kernels.Coeffs, tuple[float, float]]] = {}
        self._set_params(params if params is not None else Params())
        self.state = self._snapshot(0.0)

    # ----------------------------------------------------------------- set-up
    def _set_params(self, params: Params) -> None:
        self.params = params = checked_params(self.integrator, params, self.substeps)
        self._k, self._m, self._c, self._w = params.k, params.m, params.c, params.w
        self._hmax = params.dt / self.substeps
        self._c0 = self._coeffs_for(self._hmax)
        self._cache.clear()
        self._apply_load()

    def _apply_load(self) -> None:
        p = self.params
        n = p.m * p.g * self._load
        self._fs = p.mu_s * n
        self._fk = p.mu_k * n
        self._rs2 = (self._fs / self._k) ** 2

    def _coeffs_for(self, h: float) -> tuple[kernels.Coeffs, tuple[float, float]]:
        half = kernels.propagator(self._w, 0.5 * h)
        return kernels.propagator(self._w, h), (half[2], half[3])

    def _coeffs(self, h: float) -> tuple[kernels.Coeffs, tuple[float, float]]:
        h0 = self._hmax
        if abs(h - h0) <= 1e-12 * h0:
            return self._c0
        got = self._cache.get(h)
        if got is None:
            if len(self._cache) > 256:
                self._cache.clear()
            got = self._cache[h] = self._coeffs_for(h)
        return got

    # ---------------------------------------------------------------- advance
    def advance(
        self,
        t: float,
        samples: Iterable[Any] = (),
        *,
        params: Params | None = None,
        load_gain: float = 1.0,
    ) -> ContactState:
        """Follow every sample up to tick time t and return the state at t."""
        prev = self._t
        t = check_tick(t, prev)
        if params is not None and params is not self.params:
            self._set_params(params)
        if load_gain != self._load:
            lg = float(load_gain)
            if not (math.isfinite(lg) and lg >= 0.0):
                raise ParamError(f"load_gain must be finite and >= 0, got {load_gain!r}")
            self._load = lg
            self._apply_load()
            if self._mode == STICK and self._stretch2() > self._rs2:
                self._release(prev if prev is not None else t)
                self._rest_decide(0.0, 0.0, from_stick=True)
        cur = prev if prev is not None else -math.inf
        for s in samples:
            cur = self._take(s, cur, t)
        if self._mode <= RESTING and t > cur:
            self._run(t - cur, 0.0, 0.0, self._ux, self._uy, t)
        self._t = t
        self.state = st = self._snapshot(t)
        return st

    def _take(self, s: Any, cur: float, t: float) -> float:
        """Apply one sample; returns the time the path has reached."""
        try:
            st = float(s.t)
            sx = float(s.x)
            sy = float(s.y)
            tip = bool(s.tip)
            in_range = bool(getattr(s, "in_range", tip))
        except (AttributeError, TypeError, ValueError):
            self.rejected_samples += 1
            return cur
        if not (math.isfinite(st) and math.isfinite(sx) and math.isfinite(sy)):
            self.rejected_samples += 1
            return cur
        if st < self._last_sample_t:
            self.rejected_samples += 1
            return cur
        self._last_sample_t = st
        ts = st
        if ts > t:
            ts = t
            self.clamped_samples += 1
        elif ts < cur:
            ts = cur
            self.clamped_samples += 1
        mode = self._mode
        if mode <= RESTING:
            if tip:
                h = ts - cur
                if h > MIN_SEGMENT:
                    self._run(h, (sx - self._ux) / h, (sy - self._uy) / h, sx, sy, ts)
                else:
                    self._jump(sx, sy, ts)
            else:
                # The contact ends at this sample; until then the touch is held
                # where it was last seen touching (a lift-off sample's position
                # may already be far away, or zero on some devices).
                if ts > cur:
                    self._run(ts - cur, 0.0, 0.0, self._ux, self._uy, ts)
                self._lift(sx, sy, in_range)
        elif tip:
            self._ux = self._px = sx
            self._uy = self._py = sy
            self._vx = self._vy = 0.0
            self._mode = STICK
        else:
            self._lift(sx, sy, in_range)
        return ts

    def _lift(self, x: float, y: float, in_range: bool) -> None:
        self._ux = self._px = x
        self._uy = self._py = y
        self._vx = self._vy = 0.0
        self._mode = HOVER if in_range else UP

    def _delta(self) -> float:
        """Round-off carried by the stretch u - p at these coordinates."""
        return kernels.ROUND_OFF * (abs(self._ux) + abs(self._uy) + abs(self._px) + abs(self._py))

    def _stretch2(self) -> float:
        sx = self._ux - self._px
        sy = self._uy - self._py
        return sx * sx + sy * sy

    def _release(self, t: float) -> None:
        self.releases += 1
        self.last_release = t

    def _jump(self, x: float, y: float, t: float) -> None:
        """A sample at the same instant as the path's end: the touch jumps."""
        self._ux, self._uy = x, y
        if self._mode == STICK:
            if self._stretch2() > self._rs2:
                self._release(t)
                self._rest_decide(0.0, 0.0, from_stick=True)
        elif self._mode == RESTING:
            self._rest_decide(0.0, 0.0)

    def _rest_decide(self, udx: float, udy: float, from_stick: bool = False) -> None:
        """The pen is at rest: stick, move along the net force, or rest in slip."""
        self._vx = self._vy = 0.0
        sx = self._ux - self._px
        sy = self._uy - self._py
        if not from_stick and sx * sx + sy * sy <= self._rs2:
            self._mode = STICK
            return
        k, c = self._k, self._c
        nx = k * sx + c * udx
        ny = k * sy + c * udy
        n = math.hypot(nx, ny)
        if n > self._fk and n > 0.0:
            self._dx, self._dy = nx / n, ny / n
            self._mode = MOVING
        else:
            self._mode = RESTING

    def _start_moving(self, udx: float, udy: float) -> None:
        """The net force has just reached F_k: move along it (no re-test, which
        round-off at the crossing could fail and leave the pen resting forever)."""
        nx = self._k * (self._ux - self._px) + self._c * udx
        ny = self._k * (self._uy - self._py) + self._c * udy
        n = math.sqrt(nx * nx + ny * ny)
        if n > 0.0:
            self._dx, self._dy = nx / n, ny / n
        self._vx = self._vy = 0.0
        self._mode = MOVING

    # ------------------------------------------------------------ one segment
    def _run(self, h: float, udx: float, udy: float, u1x: float, u1y: float, t_end: float) -> None:
        """Advance over h seconds with the touch moving at (udx, udy), ending at u1 at t_end."""
        left = h
        zero_events = 0
        pieces = 0
        max_pieces = _BASE_PIECES + 64 * self.substeps
        events = self.events
        eps = 1e-13 * h
        while left > eps:
            mode = self._mode
            if mode == STICK:
                if not events:
                    self._ux, self._uy = u1x, u1y
                    if self._stretch2() > self._rs2:
                        self._release(t_end)
                        self._rest_decide(udx, udy, from_stick=True)
                    return
                tb = kernels.first_exit(
                    self._ux - self._px,
                    self._uy - self._py,
                    udx,
                    udy,
                    self._rs2,
                    left,
                    kernels.band(self._rs2, self._delta()),
                )
                if tb == kernels.NO_EVENT:
                    break
                self._ux += udx * tb
                self._uy += udy * tb
                left -= tb
                self._release(t_end - left)
                self._rest_decide(udx, udy, from_stick=True)
                consumed = tb
            elif mode == RESTING:
                k, c = self._k, self._c
                sx = self._ux - self._px
                sy = self._uy - self._py
                if not events:
                    self._ux, self._uy = u1x, u1y
                    self._rest_decide(udx, udy)
                    return
                delta = self._delta()
                fk2 = self._fk * self._fk
                ts = kernels.first_entry(
                    sx, sy, udx, udy, self._rs2, left, kernels.band(self._rs2, delta)
                )
                tm = kernels.first_exit(
                    k * sx + c * udx,
                    k * sy + c * udy,
                    k * udx,
                    k * udy,
                    fk2,
                    left,
                    kernels.band(fk2, k * delta),
                )
                tau = min(ts, tm)
                if tau == kernels.NO_EVENT:
                    break
                self._ux += udx * tau
                self._uy += udy * tau
                left -= tau
                consumed = tau
                if ts <= tau:
                    self._mode = STICK
                else:
                    self._start_moving(udx, udy)
            else:
                pieces += 1
                if pieces > max_pieces:
                    self.truncated_steps += 1
                    self._ux, self._uy = u1x, u1y
                    self._rest_decide(udx, udy)
                    return
                n = math.ceil(left / self._hmax * (1.0 - 1e-12))
                piece = left / n if n > 1 else left
                consumed, event = self._piece(piece, udx, udy)
                left -= consumed
                if event:
                    self._rest_decide(udx, udy)
            if consumed <= eps:
                zero_events += 1
                if zero_events > _MAX_ZERO_EVENTS:
                    # Should not happen; if it does, end the step in a state
                    # that is at least consistent (phase matching the tension).
                    self.event_overflows += 1
                    self._ux, self._uy = u1x, u1y
                    self._rest_decide(udx, udy)
                    return
        self._ux, self._uy = u1x, u1y

    def _piece(self, h: float, udx: float, udy: float) -> tuple[float, bool]:
        name = self.integrator
        if name == "exact":
            return self._piece_exact(h, udx, udy)
        if name == "implicit-projection":
            return self._piece_projection(h, udx, udy)
        return self._piece_explicit(h, udx, udy)

    # -------------------------------------------------------------- integrators
    def _piece_exact(self, h: float, udx: float, udy: float) -> tuple[float, bool]:
        """Closed-form slip over h, the friction direction frozen at its implicit mid-step value."""
        (c11, c12, c21, c22), (m21, m22) = self._coeffs(h)
        vx, vy = self._vx, self._vy
        sp2 = vx * vx + vy * vy
        sp = math.hypot(vx, vy)
        if sp > 0.0:
            d0x, d0y = vx / sp, vy / sp
        else:
            d0x, d0y = self._dx, self._dy
        q = self._fk / self._k
        ex = self._px - self._ux
        ey = self._py - self._uy
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
        nm = math.hypot(vmx, vmy)  # hypot: the squares of a tiny velocity underflow
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
        w = self._w
        b = w * ((ydx + w * y0x) * d0x + (ydy + w * y0y) * d0y)
        if f_h > 0.0 and (
            not self.events or (g0 + a > 0.0 and not (b + w * a > 0.0 and w * b * h > b + w * a))
        ):
            # Positive at both ends and no interior minimum (f' changes sign
            # at most once, from - to + only where f'(0) < 0 < f'(h)).
            tau = kernels.NO_EVENT
        elif not self.events:
            tau = h
        else:
            tau = kernels.rest_time(g0, a, b, w, h, f_h)
        if tau == kernels.NO_EVENT:
            ux = self._ux + udx * h
            uy = self._uy + udy * h
            px = ux - q * dx + c11 * y0x + c12 * ydx
            py = uy - q * dy + c11 * y0y + c12 * ydy
            if (
                udx == 0.0
                and udy == 0.0
                and kernels.gains_energy(
                    self._ux,
                    self._uy,
                    self._px,
                    self._py,
                    self._vx,
                    self._vy,
                    px,
                    py,
                    vnx,
                    vny,
                    self._k,
                    self._m,
                )
            ):
                # Touch held: the true motion only loses energy. In 2-D with
                # friction close to the spring force the frozen direction can
                # do a little positive work; there the pen is all but stopped,
                # so it comes to rest here (never on a straight stroke).
                self._vx = self._vy = 0.0
                return 0.0, True
            self._px, self._py = px, py
            self._ux, self._uy = ux, uy
            self._dx, self._dy = dx, dy
            if vnx * vnx + vny * vny < V_REST * V_REST and vnx * vnx + vny * vny < sp2:
                self._vx = self._vy = 0.0
                return h, True
            self._vx, self._vy = vnx, vny
            return h, False
        if tau == h:
            e11, e12 = c11, c12
        elif tau > 0.0:
            e11, e12, _, _ = kernels.propagator(w, tau)
        else:
            e11, e12 = 1.0, 0.0
        ux = self._ux + udx * tau
        uy = self._uy + udy * tau
        px = ux - q * dx + e11 * y0x + e12 * ydx
        py = uy - q * dy + e11 * y0y + e12 * ydy
        if (
            udx == 0.0
            and udy == 0.0
            and kernels.gains_energy(
                self._ux,
                self._uy,
                self._px,
                self._py,
                self._vx,
                self._vy,
                px,
                py,
                0.0,
                0.0,
                self._k,
                self._m,
            )
        ):
            self._vx = self._vy = 0.0  # as above: at rest where it is
            return 0.0, True
        self._px, self._py = px, py
        self._ux, self._uy = ux, uy
        self._vx = self._vy = 0.0
        return tau, True

    def _accel(
        self,
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
        k, c, fk, m = self._k, self._c, self._fk, self._m
        return (
            (k * (ux - px) + c * (udx - vx) - fk * dx) / m,
            (k * (uy - py) + c * (udy - vy) - fk * dy) / m,
        )

    def _step_explicit(
        self, h: float, udx: float, udy: float, dx: float, dy: float
    ) -> tuple[float, float, float, float]:
        """One step of the fixed-step integrators from the current state (no mutation)."""
        px, py, vx, vy, ux, uy = self._px, self._py, self._vx, self._vy, self._ux, self._uy
        name = self.integrator
        if name == "rk4":
            acc = self._accel
            h2 = 0.5 * h
            a1x, a1y = acc(px, py, vx, vy, ux, uy, udx, udy, dx, dy)
            p2x, p2y, v2x, v2y = px + h2 * vx, py + h2 * vy, vx + h2 * a1x, vy + h2 * a1y
            um_x, um_y = ux + udx * h2, uy + udy * h2
            a2x, a2y = acc(p2x, p2y, v2x, v2y, um_x, um_y, udx, udy, dx, dy)
            p3x, p3y, v3x, v3y = px + h2 * v2x, py + h2 * v2y, vx + h2 * a2x, vy + h2 * a2y
            a3x, a3y = acc(p3x, p3y, v3x, v3y, um_x, um_y, udx, udy, dx, dy)
            p4x, p4y, v4x, v4y = px + h * v3x, py + h * v3y, vx + h * a3x, vy + h * a3y
            a4x, a4y = acc(p4x, p4y, v4x, v4y, ux + udx * h, uy + udy * h, udx, udy, dx, dy)
            h6 = h / 6.0
            return (
                px + h6 * (vx + 2.0 * v2x + 2.0 * v3x + v4x),
                py + h6 * (vy + 2.0 * v2y + 2.0 * v3y + v4y),
                vx + h6 * (a1x + 2.0 * a2x + 2.0 * a3x + a4x),
                vy + h6 * (a1y + 2.0 * a2y + 2.0 * a3y + a4y),
            )
        ax, ay = self._accel(px, py, vx, vy, ux, uy, udx, udy, dx, dy)
        if name == "semi-implicit-euler":
            nvx, nvy = vx + h * ax, vy + h * ay
            return px + h * nvx, py + h * nvy, nvx, nvy
        return px + h * vx, py + h * vy, vx + h * ax, vy + h * ay

    def _piece_explicit(self, h: float, udx: float, udy: float) -> tuple[float, bool]:
        vx, vy = self._vx, self._vy
        sp2 = vx * vx + vy * vy
        sp = math.hypot(vx, vy)
        if sp > 0.0:
            dx, dy = vx / sp, vy / sp
        else:
            dx, dy = self._dx, self._dy
        px, py, nvx, nvy = self._step_explicit(h, udx, udy, dx, dy)
        tau = h
        event = nvx * dx + nvy * dy <= 0.0
        if event and self.events:
            lo, hi = 0.0, h
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                qx, qy, qvx, qvy = self._step_explicit(mid, udx, udy, dx, dy)
                if qvx * dx + qvy * dy > 0.0:
                    lo = mid
                else:
                    hi = mid
                    px, py = qx, qy
                if hi - lo <= 4e-16 * hi:
                    break
            tau = hi
        self._px, self._py = px, py
        self._ux += udx * tau
        self._uy += udy * tau
        self._dx, self._dy = dx, dy
        n2 = nvx * nvx + nvy * nvy
        if event or (n2 < V_REST * V_REST and n2 < sp2):
            self._vx = self._vy = 0.0
            return tau, True
        self._vx, self._vy = nvx, nvy
        return tau, False

    def _piece_projection(self, h: float, udx: float, udy: float) -> tuple[float, bool]:
        """Moreau-style implicit Euler: the friction cone decides v directly."""
        k, c, m = self._k, self._c, self._m
        vx, vy = self._vx, self._vy
        ux = self._ux + udx * h
        uy = self._uy + udy * h
        rx = m * vx + h * k * (ux - self._px) + h * c * udx
        ry = m * vy + h * k * (uy - self._py) + h * c * udy
        r = math.hypot(rx, ry)
        hf = h * self._fk
        self._ux, self._uy = ux, uy
        if r <= hf:
            self._vx = self._vy = 0.0
            return h, True
        s = (r - hf) / ((m + h * c + h * h * k) * r)
        nvx, nvy = s * rx, s * ry
        self._px += h * nvx
        self._py += h * nvy
        self._dx, self._dy = rx / r, ry / r
        n2 = nvx * nvx + nvy * nvy
        sp2 = vx * vx + vy * vy
        if (sp2 > 0.0 and nvx * vx + nvy * vy <= 0.0) or (n2 < V_REST * V_REST and n2 < sp2):
            self._vx = self._vy = 0.0
            return h, True
        self._vx, self._vy = nvx, nvy
        return h, False

    # ----------------------------------------------------------------- output
    def _snapshot(self, t: float) -> ContactState:
        mode = self._mode
        ux, uy = self._ux, self._uy
        if mode >= HOVER:
            return ContactState(t, ux, uy, ux, uy, 0.0, 0.0, _PHASE[mode], 0.0, 0.0, (0.0, 0.0))
        px, py = self._px, self._py
        sx, sy = ux - px, uy - py
        s = math.sqrt(sx * sx + sy * sy)
        tension = self._k * s
        if self.string and s > 0.0:
            string_px = self.params.C_l * math.sqrt(tension)
            sdir = (sx / s, sy / s)
        else:
            string_px = 0.0
            sdir = (0.0, 0.0)
        return ContactState(
            t, ux, uy, px, py, self._vx, self._vy, _PHASE[mode], tension, string_px, sdir
        )

    @property
    def mode(self) -> int:
        """Internal mode (STICK, MOVING, RESTING, HOVER, UP); RESTING is published as slip."""
        return self._mode


__all__ = ["INTEGRATORS", "ContactSim"]
