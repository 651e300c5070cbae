"""The real simulator behind the pipeline's SimBackend interface.

Kept apart from the pipeline so that the scene package's pipeline compiles
and is testable on its own (against any SimBackend), and so that the one
place that knows the simulator's constructor signatures is this file
(contract: stiction/sim/__init__.py). The scene package sits above the
simulator, so this imports it directly; only the batch row stepper, which
pulls in numpy and the compiled kernels, is imported when first asked for.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from stiction.errors import ParamError
from stiction.scene.pipeline import ContactModel
from stiction.sim.contact import ContactSim
from stiction.sim.integrators import INTEGRATORS, check_substeps, checked_params
from stiction.sim.params import Params

if TYPE_CHECKING:
    from stiction.sim.rows import RowStepper

PARAM_NAMES = ("k", "m", "g", "mu_s", "mu_k", "C_l", "rate")


class SimulatorBackend:
    """Params and ContactSim from stiction.sim, with one integrator choice."""

    def __init__(self, integrator: str = "default", substeps: int = 1) -> None:
        if integrator not in INTEGRATORS:
            raise ParamError(f"unknown integrator {integrator!r}; known: {', '.join(INTEGRATORS)}")
        self.integrator = integrator
        self.substeps = check_substeps(substeps)

    def defaults(self) -> dict[str, float]:
        """The simulator's own default parameters (docs/design/model.md's table)."""
        p = Params()
        return {name: float(getattr(p, name)) for name in PARAM_NAMES}

    def params(self, values: Mapping[str, float]) -> Params:
        return Params.from_mapping({k: v for k, v in values.items() if k in PARAM_NAMES})

    def check(self, params: Params) -> None:
        """Refuse `params` this backend's integrator cannot step stably.

        The row stepper checks each material only when a pipeline first ticks;
        a scene or set_params checked here is refused before it is swapped in,
        instead of failing every tick after.
        """
        checked_params(self.integrator, params, self.substeps)

    def rows(self) -> RowStepper:
        """The row stepper for the pipeline's batch step (numpy and numba: loaded on use)."""
        from stiction.sim.rows import RowStepper

        return RowStepper(self.integrator, self.substeps)

    def contact(self, params: Params, string: bool) -> ContactModel:
        return ContactSim(params, self.integrator, substeps=self.substeps, string=string)
