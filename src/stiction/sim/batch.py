"""Many contacts stepped together: one row per contact, step.py's step per row.

Each contact is a row of the (n, ROWS) array ``S`` in step.py's layout,
parameters included, so one BatchSim carries contacts on different materials
(`set_params` with ``rows``) and a contact that moves onto another material
changes its row, not its stepper. One tick runs step.advance_rows: compiled
with numba (batch_kernel.py) when numba is installed, otherwise the same
functions as plain Python (correct, and some hundred times slower).

Input is one sample per contact per tick, stamped at the tick time (a
non-finite x or y means "no usable sample": the touch is held and the sample
counted as rejected). Touch-down, lift-off, hover and up work as in
ContactSim, because they are ContactSim's own functions. Supported: "exact"
/ "default" (with event location), and "explicit-euler",
"semi-implicit-euler", "implicit-projection" without it; "rk4" has no batch
form.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from stiction.errors import ParamError
from stiction.sim import step
from stiction.sim.integrators import check_substeps, checked_params, resolve
from stiction.sim.params import Params, check_tick
from stiction.sim.state import ContactState, Phase
from stiction.sim.step import HOVER, MODE, PX, PY, UX, UY, VX, VY

F = npt.NDArray[np.float64]
_PHASES: tuple[Phase, ...] = ("stick", "slip", "slip", "hover", "up")
PHASE_CODES: tuple[Phase, ...] = ("stick", "slip", "hover", "up")
"""`phase_codes` indexes this tuple."""
_CODE = np.array([0, 1, 1, 2, 3], dtype=np.int8)

_KERNEL: Any = None
"""The batch_kernel module once imported, False if numba is missing."""


def load_kernel() -> Any:
    """The compiled loops (batch_kernel), or None without numba (imported on first use)."""
    global _KERNEL
    if _KERNEL is None:
        try:
            from stiction.sim import batch_kernel
        except ImportError:
            _KERNEL = False
        else:
            _KERNEL = batch_kernel
    return _KERNEL or None


def warm_up() -> bool:
    """Compile (or load from numba's cache) the batch loops now, not at the first tick.

    The daemon calls this before it starts its clock. False without numba.
    """
    kernel = load_kernel()
    if kernel is None:
        return False
    kernel.warm_up()
    return True


class _Interpreted:
    """step.py's loops as plain Python: what BatchSim runs without numba."""

    advance_rows = staticmethod(step.advance_rows)
    set_loads = staticmethod(step.set_loads)
    copy_params = staticmethod(step.copy_params)


def loops(compiled: bool | None) -> Any:
    """The compiled loops, or the interpreted ones (compiled=False, or no numba)."""
    if compiled is False:
        return _Interpreted
    kernel = load_kernel()
    if kernel is None:
        if compiled:
            raise ParamError("compiled=True needs numba (pip install numba)")
        return _Interpreted
    return kernel


def param_row(params: Params, integrator: str = "exact", substeps: int = 1) -> F:
    """A row holding `params` (with the events every BatchSim row uses), for copy_params."""
    r = step.new_row()
    step.set_params(
        r,
        params.k,
        params.m,
        params.g,
        params.mu_s,
        params.mu_k,
        params.C_l,
        params.dt / substeps,
        substeps,
        step.INTEGRATOR_CODES[integrator],
        integrator == "exact",
    )
    return np.array(r, dtype=np.float64)


def new_rows(n: int) -> F:
    """n fresh rows (contacts up, no parameters yet)."""
    template = np.array(step.new_row(), dtype=np.float64)
    return np.tile(template, (n, 1))


class BatchSim:
    """n contacts advanced together; ``state(i)`` equals ContactSim's to 1e-12 m."""

    def __init__(
        self,
        n: int,
        params: Params | None = None,
        integrator: str = "default",
        substeps: int = 1,
        events: bool | None = None,
        string: bool = True,
        *,
        compiled: bool | None = None,
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
        self._loops = loops(compiled)
        self.compiled = self._loops is not _Interpreted
        self.S = new_rows(n)
        self.rejected_samples = 0
        self._t: float | None = None
        self._all = np.arange(n)
        self.set_params(params if params is not None else Params())

    def set_params(self, params: Params, rows: npt.ArrayLike | None = None) -> None:
        """Give `params` to every contact, or to the contacts `rows` only (their load gain kept)."""
        checked = checked_params(self.integrator, params, self.substeps)
        src = param_row(checked, self.integrator, self.substeps)
        src[step.EVENTS] = 1.0 if self.events else 0.0
        if rows is None:
            self.params = checked
            idx = self._all
        else:
            idx = np.asarray(rows, dtype=np.int64).reshape(-1)
            if idx.size and (idx.min() < 0 or idx.max() >= self.n):
                raise ParamError(f"rows must lie in 0..{self.n - 1}")
        self._loops.copy_params(self.S, np.ascontiguousarray(idx), src)

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
        xs = np.ascontiguousarray(np.asarray(x, dtype=np.float64).reshape(self.n))
        ys = np.ascontiguousarray(np.asarray(y, dtype=np.float64).reshape(self.n))
        tips = np.ascontiguousarray(np.asarray(tip, dtype=bool).reshape(self.n))
        rng = tips if in_range is None else np.asarray(in_range, dtype=bool).reshape(self.n)
        if params is not None and params is not self.params:
            self.set_params(params)
        lg = np.broadcast_to(np.asarray(load_gain, dtype=np.float64), (self.n,))
        if not np.array_equal(lg, self.S[:, step.LOAD]):
            if not (np.all(np.isfinite(lg)) and np.all(lg >= 0.0)):
                raise ParamError("load_gain must be finite and >= 0")
            self._loops.set_loads(self.S, np.ascontiguousarray(lg), prev if prev is not None else t)
        rejected = self._loops.advance_rows(
            self.S,
            xs,
            ys,
            tips,
            np.ascontiguousarray(rng),
            t,
            prev if prev is not None else -math.inf,
        )
        self.rejected_samples += int(rejected)
        self._t = t

    # ---------------------------------------------------------------- output
    @property
    def mode(self) -> npt.NDArray[np.int8]:
        """Internal mode per contact (step.STICK, MOVING, RESTING, HOVER, UP)."""
        return self.S[:, MODE].astype(np.int8)

    @property
    def truncated_steps(self) -> int:
        return int(self.S[:, step.TRUNCATED].sum())

    @property
    def event_overflows(self) -> int:
        return int(self.S[:, step.OVERFLOWS].sum())

    @property
    def pointer(self) -> F:
        """(2, n) pointer positions; touch positions for contacts not touching."""
        return np.stack((self.S[:, PX], self.S[:, PY]))

    @property
    def touch(self) -> F:
        return np.stack((self.S[:, UX], self.S[:, UY]))

    @property
    def phase_codes(self) -> npt.NDArray[np.int8]:
        """Index into PHASE_CODES ("stick", "slip", "hover", "up") per contact."""
        return _CODE[self.mode]

    def tension(self) -> F:
        S = self.S
        sx = S[:, UX] - S[:, PX]
        sy = S[:, UY] - S[:, PY]
        t: F = S[:, step.K] * np.sqrt(sx * sx + sy * sy)
        t[S[:, MODE] >= HOVER] = 0.0
        return t

    def state(self, i: int) -> ContactState:
        """Contact i as the ContactState ContactSim would return."""
        r = self.S[i]
        t = self._t if self._t is not None else 0.0
        mode = int(r[MODE])
        ux, uy = float(r[UX]), float(r[UY])
        if mode >= HOVER:
            return ContactState(t, ux, uy, ux, uy, 0.0, 0.0, _PHASES[mode], 0.0, 0.0, (0.0, 0.0))
        px, py = float(r[PX]), float(r[PY])
        sx, sy = ux - px, uy - py
        d = math.sqrt(sx * sx + sy * sy)
        tension = float(r[step.K]) * d
        if self.string and d > 0.0:
            string_px = float(r[step.CL]) * math.sqrt(tension)
            sdir = (sx / d, sy / d)
        else:
            string_px, sdir = 0.0, (0.0, 0.0)
        return ContactState(
            t, ux, uy, px, py, float(r[VX]), float(r[VY]), _PHASES[mode], tension, string_px, sdir
        )
