"""One contact: the input path, touch-down/up, and the checks before the step.

The daemon calls `ContactSim.advance` once per contact per tick. The model
itself (stick, slip, the integrators, the events) is in step.py, written
once as free functions over a row of floats; here the row is a Python list
and those functions run as plain Python. This class checks what comes in
(tick times, samples, parameters, load gains), so nothing bad reaches the
row, and turns the row into a ContactState.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from stiction.errors import ParamError
from stiction.sim import step
from stiction.sim.integrators import INTEGRATORS, check_substeps, checked_params, resolve
from stiction.sim.params import Params, check_tick
from stiction.sim.state import ContactState, Phase
from stiction.sim.step import HOVER, MODE

_PHASE: tuple[Phase, ...] = ("stick", "slip", "slip", "hover", "up")


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
        self._unreadable = 0
        self._t: float | None = None
        self._row = step.new_row()
        self._set_params(params if params is not None else Params())
        self.state = self._snapshot(0.0)

    # ----------------------------------------------------------------- set-up
    def _set_params(self, params: Params) -> None:
        self.params = params = checked_params(self.integrator, params, self.substeps)
        step.set_params(
            self._row,
            params.k,
            params.m,
            params.g,
            params.mu_s,
            params.mu_k,
            params.C_l,
            params.dt / self.substeps,
            self.substeps,
            step.INTEGRATOR_CODES[self.integrator],
            self.events,
        )

    # --------------------------------------------------------------- counters
    @property
    def rejected_samples(self) -> int:
        """Samples dropped: unreadable, non-finite or out of order."""
        return self._unreadable + int(self._row[step.REJECTED])

    @property
    def clamped_samples(self) -> int:
        """Samples stamped after the tick (or before the path's time), used at the nearest time."""
        return int(self._row[step.CLAMPED])

    @property
    def releases(self) -> int:
        """Break-aways (stick -> slip) so far."""
        return int(self._row[step.RELEASES])

    @property
    def last_release(self) -> float:
        """Time of the latest break-away (stick -> slip), located inside the step
        when events are on, else the end of the step that detected it."""
        return self._row[step.LAST_RELEASE]

    @property
    def truncated_steps(self) -> int:
        return int(self._row[step.TRUNCATED])

    @property
    def event_overflows(self) -> int:
        return int(self._row[step.OVERFLOWS])

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
        r = self._row
        if params is not None and params is not self.params:
            self._set_params(params)
        if load_gain != r[step.LOAD]:
            lg = float(load_gain)
            if not (math.isfinite(lg) and lg >= 0.0):
                raise ParamError(f"load_gain must be finite and >= 0, got {load_gain!r}")
            step.set_load(r, lg, prev if prev is not None else t)
        cur = prev if prev is not None else -math.inf
        follow = step.sample
        for s in samples:
            # Read here rather than in a helper: one Python call less per sample.
            try:
                st = float(s.t)
                sx = float(s.x)
                sy = float(s.y)
                tip = bool(s.tip)
                in_range = bool(getattr(s, "in_range", tip))
            except (AttributeError, TypeError, ValueError):
                self._unreadable += 1
                continue
            cur = follow(r, st, sx, sy, tip, in_range, t, cur)
        step.hold(r, t, cur)
        self._t = t
        self.state = state = self._snapshot(t)
        return state

    # ----------------------------------------------------------------- output
    def _snapshot(self, t: float) -> ContactState:
        r = self._row
        mode = int(r[MODE])
        ux, uy = r[step.UX], r[step.UY]
        if mode >= HOVER:
            return ContactState(t, ux, uy, ux, uy, 0.0, 0.0, _PHASE[mode], 0.0, 0.0, (0.0, 0.0))
        px, py = r[step.PX], r[step.PY]
        sx, sy = ux - px, uy - py
        s = math.sqrt(sx * sx + sy * sy)
        tension = r[step.K] * s
        if self.string and s > 0.0:
            string_px = r[step.CL] * math.sqrt(tension)
            sdir = (sx / s, sy / s)
        else:
            string_px = 0.0
            sdir = (0.0, 0.0)
        return ContactState(
            t, ux, uy, px, py, r[step.VX], r[step.VY], _PHASE[mode], tension, string_px, sdir
        )

    @property
    def mode(self) -> int:
        """Internal mode (STICK, MOVING, RESTING, HOVER, UP); RESTING is published as slip."""
        return int(self._row[MODE])


__all__ = ["INTEGRATORS", "ContactSim"]
