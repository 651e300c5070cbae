"""step.py's loops compiled with numba: the batch stepper and the scene pipeline's.

Nothing here is physics: every function of step.py is registered so that
compiled code may call it, and the loops over rows (step.advance_rows,
set_loads, copy_params) are compiled from step.py's own
source. A contact-step without an event is then a few dozen multiply-adds on
a row that sits in one cache line or two.

Imported lazily (stiction.sim.batch.load_kernel). numba compiles on first
use and caches the machine code on disk: beside the package when that folder
is writable, else in the user's cache folder, keyed by a hash of the sources
(numba_cache.py), so a package installed read-only does not compile again at
every start and an edited step.py is never served stale. `warm_up`
compiles (or loads) everything before a caller's clock starts.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numba.extending import register_jitable  # type: ignore[import-untyped]

from stiction.sim import kernels, step
from stiction.sim.numba_cache import njit_cached

_CALLEES: tuple[Callable[..., Any], ...] = (
    kernels._f,
    kernels._polish,
    kernels.band,
    kernels.propagator,
    kernels.gains_energy,
    kernels.first_exit,
    kernels.first_entry,
    kernels.rest_time,
    step.apply_load,
    step.reset,
    step.take_params,
    step.touch_down,
    step.set_load,
    step._fill_coeffs,
    step.coeffs,
    step.sample,
    step.advance_one,
    step.take,
    step.hold,
    step.lift,
    step._delta,
    step._stretch2,
    step._release,
    step.jump,
    step.rest_decide,
    step._start_moving,
    step.run,
    step.slip_piece,
    step.piece_exact,
    step._accel,
    step.step_fixed,
    step.piece_explicit,
    step.piece_projection,
)
_INLINE = (step.advance_one, step.sample, step.take, step.hold, step.coeffs, step.slip_piece)
"""Small functions that pass arrays on: inlined at numba's IR level, which spares
a call and the reference counting of the row at every sample and piece."""
for _fn in _CALLEES:
    if _fn in _INLINE:
        register_jitable(inline="always")(_fn)
    else:
        register_jitable(_fn)


def _jit(fn: Callable[..., Any], nrt: bool = True) -> Any:
    if nrt:
        return njit_cached(fn, nogil=True)
    # numba's private switch for its runtime (``_nrt``): without it no array
    # view a loop makes of a row is reference counted. Those atomic counts,
    # at every row view and every call passing one on, cost the scene tick
    # more than its arithmetic (0.14 -> 0.05 ms for 1,000 stick-slip
    # contacts). The price: such a loop may not allocate arrays.
    return njit_cached(fn, nogil=True, _nrt=False)


advance_rows = _jit(step.advance_rows)
set_loads = _jit(step.set_loads)
copy_params = _jit(step.copy_params)


def compile_with_step(fn: Callable[..., Any], callees: tuple[Callable[..., Any], ...] = ()) -> Any:
    """numba-compile a caller's loop (the scene pipeline's tick) that calls step.py's
    functions and its own `callees` (small helpers: inlined).

    Compiled without numba's runtime: `fn` must not allocate arrays (it gets
    its scratch space from the caller), and in exchange pays no reference
    counting of the rows it passes around."""
    for callee in callees:
        register_jitable(inline="always")(callee)
    return _jit(fn, nrt=False)


def warm_up() -> None:
    """Compile (or load from the cache) every loop, on a throw-away batch of two rows."""
    from stiction.sim.batch import new_rows, param_row
    from stiction.sim.params import Params

    S = new_rows(2)
    rows = np.arange(2)
    copy_params(S, rows, param_row(Params()))
    set_loads(S, np.ones(2), 0.0)
    xs = np.array([0.0, 0.01])
    ys = np.zeros(2)
    tips = np.ones(2, dtype=bool)
    advance_rows(S, xs, ys, tips, tips, 0.0, -np.inf)
    advance_rows(S, xs + 0.01, ys, tips, tips, 0.01, 0.0)
