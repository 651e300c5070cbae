"""Test oracle: the batch stepper written a second time, over numpy arrays.

Before the step was written once (stiction/sim/step.py), this was BatchSim's
path without numba. It is kept only to check the shared step against an
independent formulation: same model, same event logic, every contact taking
the sequence of mode changes the one-contact simulator would take, but
written as array passes over a (rows, n) array. One material for all
contacts. Never used by the package.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from stiction.errors import ParamError
from stiction.sim import kernels
from stiction.sim.integrators import check_substeps, checked_params, resolve
from stiction.sim.kernels import V_REST
from stiction.sim.params import Params, check_tick
from stiction.sim.state import ContactState, Phase
from stiction.sim.step import (
    BASE_PIECES as _BASE_PIECES,
)
from stiction.sim.step import (
    HOVER,
    MIN_SEGMENT,
    MOVING,
    RESTING,
    STICK,
    UP,
)
from stiction.sim.step import (
    MAX_ZERO_EVENTS as _MAX_ZERO_EVENTS,
)

F = npt.NDArray[np.float64]
B = npt.NDArray[np.bool_]
Piece = tuple[F, F, F, F, F, F, F, F, F, B]
"""New px, py, vx, vy, ux, uy, dx, dy; time used; event mask."""

PX, PY, VX, VY, UX, UY, DX, DY, UDX, UDY, LEFT, FS2, FK, TGTX, TGTY = range(15)
_ROWS = 15
_PHASES: tuple[Phase, ...] = ("stick", "slip", "slip", "hover", "up")
PHASE_CODES: tuple[Phase, ...] = ("stick", "slip", "hover", "up")
"""`phase_codes` indexes this tuple."""
_CODE = np.array([0, 1, 1, 2, 3], dtype=np.int8)


_WARMED = False


def _warm_allocator() -> None:
    """Let glibc keep freed array memory instead of returning it to the OS.

    A tick makes a few dozen temporary arrays of n doubles; with glibc's
    default thresholds (128 KiB) freeing them trims the heap, and the next
    tick page-faults the same memory back in, which made a 10,000-contact
    step 3 to 4 times slower. Allocating and freeing one block above the mmap
    threshold makes glibc raise both thresholds itself (its documented
    dynamic behaviour); nothing else changes.
    """
    global _WARMED
    if not _WARMED:
        block = np.empty(2 * 1024 * 1024)  # 16 MiB: mmapped, then freed
        del block
        _WARMED = True


def _motion(s: F) -> tuple[F, F, F]:
    """|v|^2 and the direction of motion of every column: v/|v|, or the stored one at rest."""
    vx, vy = s[VX], s[VY]
    sp = np.hypot(vx, vy)
    has_v = sp > 0.0
    return vx * vx + vy * vy, np.where(has_v, vx / sp, s[DX]), np.where(has_v, vy / sp, s[DY])


class NumpyBatchOracle:
    """n contacts advanced together with numpy; ``state(i)`` equals ContactSim's to 1e-12 m."""

    def __init__(
        self,
        n: int,
        params: Params | None = None,
        integrator: str = "default",
        substeps: int = 1,
        events: bool | None = None,
        string: bool = True,
    ) -> None:
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ParamError(f"number of contacts must be an integer >= 1, got {n!r}")
        self.integrator = resolve(integrator)
        if self.integrator == "rk4":
            raise ParamError("rk4 has no batch form; use the default integrator in BatchSim")
        self.substeps = check_substeps(substeps)
        self.events = (self.integrator == "exact") if events is None else bool(events)
        if self.events and self.integrator != "exact":
            raise ParamError(
                f"BatchSim locates events only with the exact integrator, not {self.integrator}"
            )
        self.n = n
        self.string = bool(string)
        _warm_allocator()
        self.S = np.zeros((_ROWS, n))
        self.S[DX] = 1.0
        self.mode = np.full(n, UP, dtype=np.int8)
        self.rejected_samples = 0
        self.event_overflows = 0
        self.truncated_steps = 0
        self._t: float | None = None
        self._load: F = np.ones(n)
        self._load_scalar: float | None = 1.0
        """The load gain last given, when it was one number for all contacts."""
        self._set_params(params if params is not None else Params())

    def _set_params(self, params: Params) -> None:
        self.params = params = checked_params(self.integrator, params, self.substeps)
        self._k, self._m, self._c, self._w = params.k, params.m, params.c, params.w
        self._hmax = params.dt / self.substeps
        full = kernels.propagator(self._w, self._hmax)
        half = kernels.propagator(self._w, 0.5 * self._hmax)
        self._c0 = (*full, half[2], half[3])
        self._c0_arr = np.array(self._c0, dtype=np.float64)
        self._apply_load()

    def _apply_load(self) -> None:
        p = self.params
        nrm = p.m * p.g * self._load
        self.S[FS2] = (p.mu_s * nrm / self._k) ** 2
        self.S[FK] = p.mu_k * nrm

    # --------------------------------------------------------------- advance
    def advance(
        self,
        t: float,
        x: npt.ArrayLike,
        y: npt.ArrayLike,
        tip: npt.ArrayLike,
        *,
        in_range: npt.ArrayLike | None = None,
        params: Params | None = None,
        load_gain: float | npt.ArrayLike = 1.0,
    ) -> None:
        """Every contact takes its sample (x[i], y[i], tip[i]) stamped at tick time t."""
        prev = self._t
        t = check_tick(t, prev)
        xs = np.asarray(x, dtype=np.float64).reshape(self.n)
        ys = np.asarray(y, dtype=np.float64).reshape(self.n)
        tips = np.asarray(tip, dtype=bool).reshape(self.n)
        rng = tips if in_range is None else np.asarray(in_range, dtype=bool).reshape(self.n)
        if params is not None and params is not self.params:
            self._set_params(params)
        if not (isinstance(load_gain, float | int) and load_gain == self._load_scalar):
            self._check_load(load_gain, prev)
        self._advance_numpy(t, prev, xs, ys, tips, rng)

    def _check_load(self, load_gain: float | npt.ArrayLike, prev: float | None) -> None:
        """Take a new load gain; a stuck contact now outside its stick disc breaks away."""
        lg = np.broadcast_to(np.asarray(load_gain, dtype=np.float64), (self.n,))
        scalar = isinstance(load_gain, float | int) and not isinstance(load_gain, bool)
        if not np.array_equal(lg, self._load):
            if not (np.all(np.isfinite(lg)) and np.all(lg >= 0.0)):
                raise ParamError("load_gain must be finite and >= 0")
            self._load = lg.copy()
            self._apply_load()
            S = self.S
            st = np.nonzero(self.mode == STICK)[0]
            if st.size:
                sx = S[UX, st] - S[PX, st]
                sy = S[UY, st] - S[PY, st]
                over = st[sx * sx + sy * sy > S[FS2, st]]
                if over.size:
                    sub = S[:, over]
                    sub[UDX] = 0.0
                    sub[UDY] = 0.0
                    md = self.mode[over]
                    self._decide(sub, md, np.ones(over.size, dtype=bool))
                    S[:, over] = sub
                    self.mode[over] = md
        self._load_scalar = float(load_gain) if scalar else None  # type: ignore[arg-type]

    def _advance_numpy(self, t: float, prev: float | None, xs: F, ys: F, tips: B, rng: B) -> None:
        ok = np.isfinite(xs) & np.isfinite(ys)
        self.rejected_samples += int(self.n - np.count_nonzero(ok))
        touching = self.mode <= RESTING
        S = self.S
        lift = ok & touching & ~tips
        down = ok & ~touching & tips
        away = ok & ~touching & ~tips
        for m in (lift, away):
            if m.any():
                S[PX, m] = S[UX, m] = xs[m]
                S[PY, m] = S[UY, m] = ys[m]
                S[VX, m] = S[VY, m] = 0.0
                self.mode[m] = np.where(rng[m], HOVER, UP)
        if down.any():
            S[PX, down] = S[UX, down] = xs[down]
            S[PY, down] = S[UY, down] = ys[down]
            S[VX, down] = S[VY, down] = 0.0
            self.mode[down] = STICK
        run = touching & ~lift
        if prev is not None and run.any():
            h = t - prev
            good = ok & run
            np.copyto(S[TGTX], S[UX])
            np.copyto(S[TGTY], S[UY])
            np.copyto(S[TGTX], xs, where=good)
            np.copyto(S[TGTY], ys, where=good)
            if h > MIN_SEGMENT:
                S[UDX] = (S[TGTX] - S[UX]) / h
                S[UDY] = (S[TGTY] - S[UY]) / h
                S[LEFT] = h
                hard = self._fast(run, h)
            else:
                hard = run
            idx = np.nonzero(hard)[0]
            if idx.size:
                sub = S[:, idx]
                md = self.mode[idx]
                if h > MIN_SEGMENT:
                    self._run(sub, md, h)
                else:
                    self._jump(sub, md, good[idx])
                S[:, idx] = sub
                self.mode[idx] = md
            np.copyto(S[UX], S[TGTX], where=run)
            np.copyto(S[UY], S[TGTY], where=run)
        self._t = t

    def _jump(self, sub: F, md: npt.NDArray[np.int8], good: B) -> None:
        sub[UX] = sub[TGTX]
        sub[UY] = sub[TGTY]
        sub[UDX] = 0.0
        sub[UDY] = 0.0
        sx = sub[UX] - sub[PX]
        sy = sub[UY] - sub[PY]
        st = good & (md == STICK) & (sx * sx + sy * sy > sub[FS2])
        rs = good & (md == RESTING)
        for mask, from_stick in ((st, True), (rs, False)):
            ii = np.nonzero(mask)[0]
            if ii.size:
                s2 = sub[:, ii]
                m2 = md[ii]
                self._decide(s2, m2, np.full(ii.size, from_stick))
                sub[:, ii] = s2
                md[ii] = m2

    def _decide(self, s: F, md: npt.NDArray[np.int8], from_stick: B) -> None:
        """Rest decision (ContactSim._rest_decide) for every column of s."""
        s[VX] = 0.0
        s[VY] = 0.0
        sx = s[UX] - s[PX]
        sy = s[UY] - s[PY]
        stick = ~from_stick & (sx * sx + sy * sy <= s[FS2])
        nx = self._k * sx + self._c * s[UDX]
        ny = self._k * sy + self._c * s[UDY]
        nn = np.hypot(nx, ny)
        move = ~stick & (nn > s[FK]) & (nn > 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            s[DX] = np.where(move, nx / nn, s[DX])
            s[DY] = np.where(move, ny / nn, s[DY])
        md[:] = np.where(stick, STICK, np.where(move, MOVING, RESTING))

    # ------------------------------------------------------------- segments
    def _run(self, sub: F, md: npt.NDArray[np.int8], h: float) -> None:
        eps = 1e-13 * h
        zero = np.zeros(sub.shape[1], dtype=np.int32)
        pieces = np.zeros(sub.shape[1], dtype=np.int64)
        max_pieces = _BASE_PIECES + 64 * self.substeps
        live = np.ones(sub.shape[1], dtype=bool)
        with np.errstate(all="ignore"):
            while True:
                live &= sub[LEFT] > eps
                if not live.any():
                    return
                consumed = np.full(sub.shape[1], np.inf)
                for mode, fn in (
                    (STICK, self._stick),
                    (RESTING, self._resting),
                    (MOVING, self._moving),
                ):
                    ii = np.nonzero(live & (md == mode))[0]
                    if mode == MOVING and ii.size:
                        # Counted here, not at the top of the pass: a contact
                        # released from stick earlier in this pass takes its
                        # first piece now, and ContactSim counts that piece.
                        pieces[ii] += 1
                        cut = np.zeros(sub.shape[1], dtype=bool)
                        cut[ii[pieces[ii] > max_pieces]] = True
                        if cut.any():
                            # As ContactSim: a long gap ends at rest (see _BASE_PIECES).
                            self.truncated_steps += self._end_step(sub, md, cut, live)
                            ii = ii[~cut[ii]]
                    if ii.size:
                        s2 = sub[:, ii]
                        m2 = md[ii]
                        done, used = fn(s2, m2)
                        sub[:, ii] = s2
                        md[ii] = m2
                        live[ii[done]] = False
                        consumed[ii] = used
                z = live & (consumed <= eps)
                zero[z] += 1
                over = live & (zero > _MAX_ZERO_EVENTS)
                if over.any():
                    # As ContactSim: end the step consistently (see _run there).
                    self.event_overflows += self._end_step(sub, md, over, live)

    def _end_step(self, sub: F, md: npt.NDArray[np.int8], mask: B, live: B) -> int:
        """Cut the step short for the mask's contacts: touch at its target, rest
        decision, no longer live. Returns how many there were."""
        sub[UX, mask] = sub[TGTX, mask]
        sub[UY, mask] = sub[TGTY, mask]
        self._decide_subset(sub, md, mask, False)
        live &= ~mask
        return int(np.count_nonzero(mask))

    def _stick(self, s: F, md: npt.NDArray[np.int8]) -> tuple[B, F]:
        if not self.events:
            s[UX] = s[TGTX]
            s[UY] = s[TGTY]
            sx = s[UX] - s[PX]
            sy = s[UY] - s[PY]
            rel = sx * sx + sy * sy > s[FS2]
            if rel.any():
                self._decide_subset(s, md, rel, True)
            s[LEFT] = 0.0
            return np.ones(s.shape[1], dtype=bool), np.zeros(s.shape[1])
        tb = first_exit_v(
            s[UX] - s[PX],
            s[UY] - s[PY],
            s[UDX],
            s[UDY],
            s[FS2],
            s[LEFT],
            band_v(s[FS2], delta_v(s)),
        )
        none = np.isinf(tb)
        tb0 = np.where(none, 0.0, tb)
        s[UX] += s[UDX] * tb0
        s[UY] += s[UDY] * tb0
        s[LEFT] = np.where(none, 0.0, s[LEFT] - tb0)
        rel = ~none
        if rel.any():
            self._decide_subset(s, md, rel, True)
        return none, tb0

    def _decide_subset(self, s: F, md: npt.NDArray[np.int8], mask: B, from_stick: bool) -> None:
        ii = np.nonzero(mask)[0]
        s2 = s[:, ii]
        m2 = md[ii]
        self._decide(s2, m2, np.full(ii.size, from_stick))
        s[:, ii] = s2
        md[ii] = m2

    def _resting(self, s: F, md: npt.NDArray[np.int8]) -> tuple[B, F]:
        k, c = self._k, self._c
        if not self.events:
            s[UX] = s[TGTX]
            s[UY] = s[TGTY]
            self._decide(s, md, np.zeros(s.shape[1], dtype=bool))
            s[LEFT] = 0.0
            return np.ones(s.shape[1], dtype=bool), np.zeros(s.shape[1])
        sx = s[UX] - s[PX]
        sy = s[UY] - s[PY]
        delta = delta_v(s)
        fk2 = s[FK] * s[FK]
        ts = first_entry_v(sx, sy, s[UDX], s[UDY], s[FS2], s[LEFT], band_v(s[FS2], delta))
        tm = first_exit_v(
            k * sx + c * s[UDX],
            k * sy + c * s[UDY],
            k * s[UDX],
            k * s[UDY],
            fk2,
            s[LEFT],
            band_v(fk2, k * delta),
        )
        tau = np.minimum(ts, tm)
        none = np.isinf(tau)
        t0 = np.where(none, 0.0, tau)
        s[UX] += s[UDX] * t0
        s[UY] += s[UDY] * t0
        s[LEFT] = np.where(none, 0.0, s[LEFT] - t0)
        to_stick = ~none & (ts <= tau)
        md[to_stick] = STICK
        s[VX, to_stick] = 0.0
        s[VY, to_stick] = 0.0
        mv = ~none & ~to_stick
        if mv.any():
            nx = k * (s[UX] - s[PX]) + c * s[UDX]
            ny = k * (s[UY] - s[PY]) + c * s[UDY]
            nn = np.hypot(nx, ny)
            ok = mv & (nn > 0.0)
            s[DX] = np.where(ok, nx / nn, s[DX])
            s[DY] = np.where(ok, ny / nn, s[DY])
            s[VX, mv] = 0.0
            s[VY, mv] = 0.0
            md[mv] = MOVING
        return none, t0

    def _moving(self, s: F, md: npt.NDArray[np.int8]) -> tuple[B, F]:
        left = s[LEFT]
        hmax = self._hmax
        npieces = np.ceil(left / hmax * (1.0 - 1e-12))
        piece = np.where(npieces > 1, left / npieces, left)
        px, py, vx, vy, ux, uy, dx, dy, used, event = self._piece(s, piece, None)
        s[PX], s[PY], s[VX], s[VY], s[UX], s[UY], s[DX], s[DY] = px, py, vx, vy, ux, uy, dx, dy
        s[LEFT] = left - used
        if event.any():
            self._decide_subset(s, md, event, False)
        return np.zeros(s.shape[1], dtype=bool), used

    def _piece(self, s: F, h: Any, mask: B | None) -> Piece:
        """One slip piece for every column; returns new rows, time used and the event mask.

        Does not write into s, so the fast path can run it over all contacts
        and keep only the results of those without an event.
        """
        if self.integrator == "exact":
            return self._piece_exact(s, h, mask)
        if self.integrator == "implicit-projection":
            return self._piece_projection(s, h)
        return self._piece_explicit(s, h)

    def _coeffs(self, piece: Any) -> tuple[Any, ...]:
        hmax = self._hmax
        if isinstance(piece, float):
            std_all = abs(piece - hmax) <= 1e-12 * hmax
            if std_all:
                return self._c0
            piece = np.asarray([piece], dtype=np.float64)
        std = np.abs(piece - hmax) <= 1e-12 * hmax
        if std.all():
            return self._c0
        full = propagator_v(self._w, piece)
        half = propagator_v(self._w, 0.5 * piece)
        c0 = self._c0
        return (
            np.where(std, c0[0], full[0]),
            np.where(std, c0[1], full[1]),
            np.where(std, c0[2], full[2]),
            np.where(std, c0[3], full[3]),
            np.where(std, c0[4], half[2]),
            np.where(std, c0[5], half[3]),
        )

    def _piece_exact(self, s: F, h: Any, mask: B | None) -> Piece:
        c11, c12, c21, c22, m21, m22 = self._coeffs(h)
        w = self._w
        vx, vy = s[VX], s[VY]
        udx, udy = s[UDX], s[UDY]
        sp2, d0x, d0y = _motion(s)
        q = s[FK] / self._k
        ex = s[PX] - s[UX]
        ey = s[PY] - s[UY]
        ydx = vx - udx
        ydy = vy - udy
        vmx = udx + m21 * ex + m22 * ydx  # implicit mid-step direction (see contact.py)
        vmy = udy + m21 * ey + m22 * ydy
        nm = np.hypot(vmx, vmy)
        fwd = (vmx * d0x + vmy * d0y > 0.0) & (nm > 0.0)
        dx = np.where(fwd, vmx / nm, d0x)
        dy = np.where(fwd, vmy / nm, d0y)
        y0x = ex + q * dx
        y0y = ey + q * dy
        vnx = udx + c21 * y0x + c22 * ydx
        vny = udy + c21 * y0y + c22 * ydy
        f_h = vnx * d0x + vny * d0y
        g0 = udx * d0x + udy * d0y
        a = ydx * d0x + ydy * d0y
        b = w * ((ydx + w * y0x) * d0x + (ydy + w * y0y) * d0y)
        hh = np.broadcast_to(h, f_h.shape)
        tau = np.full(f_h.shape, np.inf)
        dd = b + w * a
        check = ~((f_h > 0.0) & (g0 + a > 0.0) & ~((dd > 0.0) & (w * b * hh > dd)))
        if mask is not None:
            check &= mask
        if check.any():
            ci = np.nonzero(check)[0]
            tau[ci] = rest_time_v(g0[ci], a[ci], b[ci], w, hh[ci], f_h[ci])
        noev = np.isinf(tau)
        if noev.all():
            t_used = hh
            e11, e12 = c11, c12
        else:
            t_used = np.where(noev, hh, tau)
            e = propagator_v(w, t_used)
            e11 = np.where(t_used == hh, c11, np.where(t_used > 0.0, e[0], 1.0))
            e12 = np.where(t_used == hh, c12, np.where(t_used > 0.0, e[1], 0.0))
        ux = s[UX] + udx * t_used
        uy = s[UY] + udy * t_used
        px = ux - q * dx + e11 * y0x + e12 * ydx
        py = uy - q * dy + e11 * y0y + e12 * ydy
        n2 = vnx * vnx + vny * vny
        event = ~noev | ((n2 < V_REST * V_REST) & (n2 < sp2))
        held = (udx == 0.0) & (udy == 0.0)
        if held.any():
            # ContactSim._gains_energy: a held-touch step (or step to a rest
            # event) that would gain energy is the pen at rest where it is.
            k, m = self._k, self._m
            sx0, sy0 = s[UX] - s[PX], s[UY] - s[PY]
            sx1, sy1 = s[UX] - px, s[UY] - py
            s02 = sx0 * sx0 + sy0 * sy0
            e0 = m * sp2 + k * s02
            e1 = m * np.where(noev, n2, 0.0) + k * (sx1 * sx1 + sy1 * sy1)
            d = delta_v(s)
            gain = held & (e1 > e0 * (1.0 + 1e-12) + 2.0 * k * d * (2.0 * np.sqrt(s02) + d))
            if gain.any():
                event = event | gain
                t_used = np.where(gain, 0.0, t_used)
                px = np.where(gain, s[PX], px)
                py = np.where(gain, s[PY], py)
                ux = np.where(gain, s[UX], ux)
                uy = np.where(gain, s[UY], uy)
                noev = noev & ~gain
        return (
            px,
            py,
            np.where(event, 0.0, vnx),
            np.where(event, 0.0, vny),
            ux,
            uy,
            np.where(noev, dx, s[DX]),
            np.where(noev, dy, s[DY]),
            t_used,
            event,
        )

    def _piece_explicit(self, s: F, h: Any) -> Piece:
        k, c, m = self._k, self._c, self._m
        vx, vy = s[VX], s[VY]
        sp2, dx, dy = _motion(s)
        fk = s[FK]
        ax = (k * (s[UX] - s[PX]) + c * (s[UDX] - vx) - fk * dx) / m
        ay = (k * (s[UY] - s[PY]) + c * (s[UDY] - vy) - fk * dy) / m
        nvx, nvy = vx + h * ax, vy + h * ay
        if self.integrator == "semi-implicit-euler":
            px, py = s[PX] + h * nvx, s[PY] + h * nvy
        else:
            px, py = s[PX] + h * vx, s[PY] + h * vy
        n2 = nvx * nvx + nvy * nvy
        event = (nvx * dx + nvy * dy <= 0.0) | ((n2 < V_REST * V_REST) & (n2 < sp2))
        used: F = np.broadcast_to(h, px.shape)
        return (
            px,
            py,
            np.where(event, 0.0, nvx),
            np.where(event, 0.0, nvy),
            s[UX] + s[UDX] * h,
            s[UY] + s[UDY] * h,
            dx,
            dy,
            used,
            event,
        )

    def _piece_projection(self, s: F, h: Any) -> Piece:
        k, c, m = self._k, self._c, self._m
        vx, vy = s[VX], s[VY]
        ux = s[UX] + s[UDX] * h
        uy = s[UY] + s[UDY] * h
        rx = m * vx + h * k * (ux - s[PX]) + h * c * s[UDX]
        ry = m * vy + h * k * (uy - s[PY]) + h * c * s[UDY]
        r = np.hypot(rx, ry)
        hf = h * s[FK]
        held = r <= hf
        sc = np.where(held, 0.0, (r - hf) / ((m + h * c + h * h * k) * r))
        nvx, nvy = sc * rx, sc * ry
        n2 = nvx * nvx + nvy * nvy
        sp2 = vx * vx + vy * vy
        event = (
            held
            | ((sp2 > 0.0) & (nvx * vx + nvy * vy <= 0.0))
            | ((n2 < V_REST * V_REST) & (n2 < sp2))
        )
        used: F = np.broadcast_to(h, ux.shape)
        return (
            s[PX] + h * nvx,
            s[PY] + h * nvy,
            np.where(event, 0.0, nvx),
            np.where(event, 0.0, nvy),
            ux,
            uy,
            np.where(held, s[DX], rx / r),
            np.where(held, s[DY], ry / r),
            used,
            event,
        )

    def _fast(self, run: B, h: float) -> B:
        """Apply every contact whose tick is a single piece with no event; return the rest.

        A stuck contact whose touch ends inside the stick disc stays stuck all
        tick (the path is a straight segment and the disc is convex); a
        sliding contact whose one piece has no event is applied directly.
        Both are computed over the full arrays with the same formulas the
        general loop uses, so the results are identical.
        """
        with np.errstate(all="ignore"):
            return self._fast_inner(run, h)

    def _fast_inner(self, run: B, h: float) -> B:
        S = self.S
        md = self.mode
        sx = S[TGTX] - S[PX]
        sy = S[TGTY] - S[PY]
        stuck = run & (md == STICK) & (sx * sx + sy * sy <= S[FS2])
        easy = stuck
        if abs(h - self._hmax) <= 1e-12 * self._hmax:
            moving = run & (md == MOVING)
            if moving.any():
                px, py, vx, vy, _, _, dx, dy, _, event = self._piece(S, h, moving)
                ok = moving & ~event
                for row, val in ((PX, px), (PY, py), (VX, vx), (VY, vy), (DX, dx), (DY, dy)):
                    np.copyto(S[row], val, where=ok)
                easy = stuck | ok
        hard: B = run & ~easy
        return hard

    # ---------------------------------------------------------------- output
    @property
    def pointer(self) -> F:
        """(2, n) pointer positions; touch positions for contacts not touching."""
        return self.S[[PX, PY]]

    @property
    def touch(self) -> F:
        return self.S[[UX, UY]]

    @property
    def phase_codes(self) -> npt.NDArray[np.int8]:
        """Index into PHASE_CODES ("stick", "slip", "hover", "up") per contact."""
        return _CODE[self.mode]

    def tension(self) -> F:
        sx = self.S[UX] - self.S[PX]
        sy = self.S[UY] - self.S[PY]
        t: F = self._k * np.sqrt(sx * sx + sy * sy)
        t[self.mode >= HOVER] = 0.0
        return t

    def state(self, i: int) -> ContactState:
        """Contact i as the ContactState ContactSim would return."""
        S = self.S
        t = self._t if self._t is not None else 0.0
        mode = int(self.mode[i])
        ux, uy = float(S[UX, i]), float(S[UY, i])
        if mode >= HOVER:
            return ContactState(t, ux, uy, ux, uy, 0.0, 0.0, _PHASES[mode], 0.0, 0.0, (0.0, 0.0))
        px, py = float(S[PX, i]), float(S[PY, i])
        sx, sy = ux - px, uy - py
        d = math.sqrt(sx * sx + sy * sy)
        tension = self._k * d
        if self.string and d > 0.0:
            string_px = self.params.C_l * math.sqrt(tension)
            sdir = (sx / d, sy / d)
        else:
            string_px, sdir = 0.0, (0.0, 0.0)
        return ContactState(
            t,
            ux,
            uy,
            px,
            py,
            float(S[VX, i]),
            float(S[VY, i]),
            _PHASES[mode],
            tension,
            string_px,
            sdir,
        )


# ------------------------------------------------------------ vector kernels
def propagator_v(w: float, h: F) -> tuple[F, F, F, F]:
    wh = w * h
    e = np.where(wh > kernels.EXP_CUTOFF, 0.0, np.exp(-np.minimum(wh, kernels.EXP_CUTOFF)))
    out = (e * (1.0 + wh), e * h, -e * w * w * h, e * (1.0 - wh))
    return tuple(np.where(np.abs(c) >= kernels.TINY, c, 0.0) for c in out)  # type: ignore[return-value]


def band_v(r2: F, delta: F) -> F:
    out: F = kernels.BOUNDARY * r2 + delta * (2.0 * np.sqrt(r2) + delta)
    return out


def delta_v(s: F) -> F:
    out: F = kernels.ROUND_OFF * (np.abs(s[UX]) + np.abs(s[UY]) + np.abs(s[PX]) + np.abs(s[PY]))
    return out


def first_exit_v(a0x: F, a0y: F, a1x: F, a1y: F, r2: F, hmax: F, tol: F) -> F:
    """kernels.first_exit over arrays; inf where there is no crossing."""
    c = a0x * a0x + a0y * a0y - r2
    a = a1x * a1x + a1y * a1y
    b = 2.0 * (a0x * a1x + a0y * a1y)
    sq = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    inner = np.where(b <= 0.0, (-b + sq) / (2.0 * a), (2.0 * c) / (-b - sq))
    tau = np.where(c >= -tol, -b / a, inner)
    tau = np.where((a == 0.0) | (tau > hmax) | np.isnan(tau), np.inf, np.maximum(tau, 0.0))
    out: F = np.where((c > tol) | ((c > -tol) & (b > 0.0)), 0.0, tau)
    return out


def first_entry_v(a0x: F, a0y: F, a1x: F, a1y: F, r2: F, hmax: F, tol: F) -> F:
    c = a0x * a0x + a0y * a0y - r2
    a = a1x * a1x + a1y * a1y
    b = 2.0 * (a0x * a1x + a0y * a1y)
    disc = b * b - 4.0 * a * c
    q = 0.5 * (-b + np.sqrt(np.maximum(disc, 0.0)))
    tau = c / q
    bad = (a == 0.0) | (b >= 0.0) | (c <= tol) | (disc < 0.0) | (tau > hmax) | np.isnan(tau)
    now = (c < -tol) | ((c <= tol) & (b < 0.0))
    out: F = np.where(now, 0.0, np.where(bad, np.inf, tau))
    return out


def rest_time_v(g0: F, a: F, b: F, w: float, h: F, f_h: F) -> F:
    """kernels.rest_time over arrays; inf where the pen does not come to rest."""
    f0 = g0 + a
    d0 = -(b + w * a)
    tc = np.where(b != 0.0, 1.0 / w + a / b, -1.0)
    interior = (tc > 0.0) & (tc < h)
    fc = g0 + (a - b * tc) * np.exp(-w * np.where(interior, tc, 0.0))
    tau = np.full(h.shape, np.inf)
    lo = np.zeros(h.shape)
    hi = h.copy()
    neg = f_h <= 0.0
    c1 = neg & (f0 > 0.0)
    c2 = neg & ~c1 & (d0 > 0.0) & interior & (fc > 0.0)
    tau[neg & ~c1 & ~c2] = 0.0
    lo[c2] = tc[c2]
    pos = ~neg & (f0 > 0.0)  # from rest and moving forward at h: no event (kernels)
    pint = pos & (d0 < 0.0) & interior
    c3 = pint & (fc <= 0.0)
    hi[c3] = tc[c3]
    need = c1 | c2 | c3
    if need.any():
        ii = np.nonzero(need)[0]
        tau[ii] = _polish_v(g0[ii], a[ii], b[ii], w, lo[ii], hi[ii])
    return tau


def _polish_v(g0: F, a: F, b: F, w: float, lo: F, hi: F) -> F:
    """kernels._polish over arrays, each element stopping where the scalar one would."""
    lo = lo.copy()
    hi = hi.copy()
    tau = 0.5 * (lo + hi)
    out = tau.copy()
    done = np.zeros(tau.shape, dtype=bool)
    for _ in range(64):
        e = np.exp(-w * tau)
        f = g0 + (a - b * tau) * e
        pos = f > 0.0
        lo = np.where(pos, tau, lo)
        hi = np.where(pos, hi, tau)
        fp = e * (w * b * tau - b - w * a)
        nz = fp != 0.0
        step = np.where(nz, f / np.where(nz, fp, 1.0), np.inf)
        conv = ~done & (np.abs(step) <= 4e-16 * tau + 1e-300)
        out[conv] = tau[conv]
        done |= conv
        mid = 0.5 * (lo + hi)
        nxt = tau - step
        inside = (lo < nxt) & (nxt < hi)
        nxt = np.where(inside, nxt, mid)
        flat = ~done & ~inside & ((mid == lo) | (mid == hi))
        out[flat] = hi[flat]
        done |= flat
        if done.all():
            return out
        tau = np.where(done, tau, nxt)
    out[~done] = tau[~done]
    return out
