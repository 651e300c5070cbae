"""The stick-slip model of docs (docs/design/model.md): parameters, integrators, batch stepping.

CONTRACT (other packages code against this; keep it stable, extend it freely):

``Params`` -- frozen, validated dataclass. Fields k=0.1 N/m, m=1e-4 kg,
g=9.8 m/s^2, mu_s=0.7, mu_k=0.1, C_l=2000 px/sqrt(N), rate=100 Hz; derived
properties ``c`` (critical damping 2*sqrt(m*k)), ``dt`` (1/rate), ``F_s``
(mu_s*m*g) and ``F_k`` (mu_k*m*g). A zero, negative, NaN or infinite value
raises ``stiction.errors.ParamError`` naming the parameter (mu_s and mu_k may be
0). ``Params.replace(**changes)`` and ``Params.from_mapping(dict)`` validate too.

``Touch(t, x, y, tip=True, pressure=None)`` -- a NamedTuple input sample. Any
object with attributes ``t, x, y, tip`` (and optionally ``pressure``,
``in_range``) is accepted, so ``stiction.drivers.PenSample`` can be passed
directly.

``ContactState`` -- frozen dataclass: ``t, touch_x, touch_y, pointer_x,
pointer_y, vx, vy, phase`` ("stick" | "slip" | "hover" | "up"), ``tension``
(N), ``string_px`` (0.0 when the string is off), ``string_dir`` ((dx, dy) unit
vector from pointer toward touch, (0.0, 0.0) when undefined).

``ContactSim(params, integrator="default", substeps=1, events=None, string=True)``
-- one contact. ``advance(t, samples, *, params=None, load_gain=1.0) ->
ContactState`` takes every input sample with previous_tick < sample.t <= t, in
order, follows the piecewise-linear touch path they define (docs/design/model.md "Input
path"), handles touch-down / touch-up / hover inside the tick, and returns the
state at tick time ``t``. ``params`` switches the material from this tick on;
``load_gain`` scales the normal load N = m*g*load_gain (pressure_load effect).
Non-finite or out-of-order samples are dropped without touching the state and
counted in ``rejected_samples``. ``state`` is the last returned ContactState.

``BatchSim`` -- many independent contacts stepped together (one row per
contact, step.py's step compiled with numba), equal to ContactSim to 1e-12 m.

``INTEGRATORS`` -- the names accepted: "explicit-euler", "semi-implicit-euler",
"rk4", "implicit-projection", "exact", and "default" (an alias chosen in
docs/accuracy.md). ``DEFAULT_INTEGRATOR`` is the name "default" resolves to.

EXTENSIONS (beyond the contract above, all optional):

- ``ContactSim(..., events=None)``: sub-tick event location (break-away found
  on the quadratic stick bound, rest found inside the step) -- on by default
  for "exact", off for the fixed-step integrators, available for all.
- A fixed-step integrator whose step would be unstable at the given k, m,
  rate and substeps (explicit Euler at w*dt > 2, ...) is refused with a
  ``ParamError`` naming the substep count that would work.
- ``ContactSim.clamped_samples``: samples stamped after the tick (or before
  the path's current time) are used at the nearest allowed time and counted;
  ``event_overflows`` counts pathological steps cut short.
- Samples without an ``in_range`` attribute (``Touch``) end a contact as "up";
  ``PenSample`` with ``in_range=True`` and ``tip=False`` gives "hover".
- ``Params`` also refuses a rate above 1 MHz and values whose derived
  quantities overflow (k = 1e-300, m = 1e300, ...), with a ParamError.
- A segment needing more than 1000 + 64*substeps pieces (a tick hours late)
  ends at rest; counted in ``truncated_steps`` (ContactSim and BatchSim).
- ``Params.w`` (sqrt(k/m)); ``ContactSim.mode`` (internal mode, RESTING is
  the "slip" phase at rest); ``ContactSim.releases`` / ``last_release``
  (count and time of break-aways, located inside the step with events on).
- ``BatchSim(n, params=None, integrator="default", substeps=1, events=None,
  string=True)``; ``advance(t, x, y, tip, *, in_range=None, params=None,
  load_gain=1.0)`` takes one sample per contact stamped at tick time t
  (arrays of length n; a non-finite x or y holds the touch and counts in
  ``rejected_samples``); ``state(i)`` is contact i as a ContactState,
  ``pointer`` / ``touch`` are (2, n) arrays, ``phase_codes`` index
  ``stiction.sim.batch.PHASE_CODES``, ``tension()``. Integrators: exact
  (default, with events), explicit-euler, semi-implicit-euler,
  implicit-projection (without events); rk4 has no batch form.
- The step is written once (``stiction.sim.step``: free functions over one
  row layout, run as Python by ContactSim, compiled by batch_kernel.py).
  ``BatchSim.set_params(params, rows=...)`` gives some contacts another
  material; ``stiction.sim.batch.warm_up()`` compiles (or loads from numba's
  cache) the batch loops ahead of time; ``stiction.sim.rows.RowStepper`` is
  the scene pipeline's view of the rows.
- The exact integrator freezes the friction direction over a step at the
  implicit mid-step velocity direction (see contact.py): exact on straight
  strokes, second order in the turning of the direction in 2-D, and stable
  where friction dominates the pen's momentum.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from stiction.lazy import exports as _exports

if TYPE_CHECKING:
    from stiction.sim.batch import BatchSim
    from stiction.sim.contact import ContactSim
    from stiction.sim.integrators import DEFAULT_INTEGRATOR, INTEGRATORS
    from stiction.sim.params import Params
    from stiction.sim.state import ContactState, Phase, Touch

__all__ = [
    "DEFAULT_INTEGRATOR",
    "INTEGRATORS",
    "BatchSim",
    "ContactSim",
    "ContactState",
    "Params",
    "Phase",
    "Touch",
]

# The names above are imported on first use (PEP 562), not with the package:
# BatchSim needs numpy, and `stiction --help` imports stiction.sim.cli and so
# this package. Type checkers read the TYPE_CHECKING imports instead.
_SOURCES = {
    "BatchSim": "stiction.sim.batch",
    "ContactSim": "stiction.sim.contact",
    "DEFAULT_INTEGRATOR": "stiction.sim.integrators",
    "INTEGRATORS": "stiction.sim.integrators",
    "Params": "stiction.sim.params",
    "ContactState": "stiction.sim.state",
    "Phase": "stiction.sim.state",
    "Touch": "stiction.sim.state",
}


_lazy, __dir__ = _exports(__name__, _SOURCES, globals(), __all__)

if not TYPE_CHECKING:
    # Hidden from type checkers: a visible module __getattr__ would make them
    # accept any misspelt name imported from this package.
    __getattr__ = _lazy
