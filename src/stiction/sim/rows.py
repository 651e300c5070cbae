"""The row stepper the scene pipeline drives: rows of step.py's layout, one call per tick.

The pipeline keeps one row per live contact of a device and, each tick,
advances every row that has friction with one call (compiled with numba
when it is installed). This is its whole view of the simulator: the row
layout's named fields, fresh rows, a row per parameter set, and the loops.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from stiction.sim import step
from stiction.sim.batch import loops, new_rows, param_row
from stiction.sim.integrators import check_substeps, checked_params, resolve
from stiction.sim.params import Params

F = npt.NDArray[np.float64]


class RowStepper:
    """Rows for one integrator choice; the same results as one ContactSim per row."""

    ROWS = step.ROWS
    PX, PY, UX, UY, MODE, K, CL, LOAD, PID, TICK, LAST_SAMPLE = (
        step.PX,
        step.PY,
        step.UX,
        step.UY,
        step.MODE,
        step.K,
        step.CL,
        step.LOAD,
        step.PID,
        step.TICK,
        step.LAST_SAMPLE,
    )
    STICK, HOVER = step.STICK, step.HOVER
    PARAMS = slice(step.PARAM_FIRST, step.PARAM_END)

    def __init__(self, integrator: str = "default", substeps: int = 1) -> None:
        self.integrator = resolve(integrator)
        self.substeps = check_substeps(substeps)
        self.loops: Any = loops(None)

    def new_rows(self, n: int) -> F:
        return new_rows(n)

    def param_row(self, params: Params) -> F:
        checked = checked_params(self.integrator, params, self.substeps)
        return param_row(checked, self.integrator, self.substeps)

    def compile(self, fn: Any, callees: tuple[Any, ...] = ()) -> Any:
        """fn compiled with numba (it may call step.py's functions and `callees`),
        or fn itself without numba."""
        kernel = self.loops
        if hasattr(kernel, "compile_with_step"):
            return kernel.compile_with_step(fn, callees)
        return fn

    def is_cached(self, compiled: Any) -> bool | None:
        """Whether numba's cache holds `compiled` (what `compile` returned); None: unknown."""
        from stiction.sim.numba_cache import is_cached

        return is_cached(compiled)
