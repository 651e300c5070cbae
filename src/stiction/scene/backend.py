"""The real simulator behind the pipeline's SimBackend interface.

Kept apart from the pipeline so that the scene package compiles and is
testable on its own, and so that the one place that knows the simulator's
constructor signature is this file (contract: stiction/sim/__init__.py).
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any, cast

from stiction.errors import ParamError, StictionError
from stiction.scene.pipeline import ContactModel

PARAM_NAMES = ("k", "m", "g", "mu_s", "mu_k", "C_l", "rate")


class SimulatorBackend:
    """Params and ContactSim from stiction.sim, with one integrator choice."""

    def __init__(self, integrator: str = "default", substeps: int = 1) -> None:
        sim = importlib.import_module("stiction.sim")
        self._params_cls: Any = getattr(sim, "Params", None)
        self._contact_cls: Any = getattr(sim, "ContactSim", None)
        if self._params_cls is None or self._contact_cls is None:
            raise StictionError("the simulator (stiction.sim) is not available in this build")
        known = getattr(sim, "INTEGRATORS", None)
        if known is not None and integrator not in known:
            raise ParamError(f"unknown integrator {integrator!r}; known: {', '.join(known)}")
        if substeps < 1:
            raise ParamError(f"substeps must be at least 1, got {substeps}")
        self.integrator = integrator
        self.substeps = substeps

    def defaults(self) -> dict[str, float]:
        """The simulator's own default parameters (docs/design/model.md's table)."""
        p = self._params_cls()
        return {name: float(getattr(p, name)) for name in PARAM_NAMES}

    def params(self, values: Mapping[str, float]) -> Any:
        return self._params_cls.from_mapping({k: v for k, v in values.items() if k in PARAM_NAMES})

    def rows(self) -> Any:
        """The row stepper for the pipeline's batch step (stiction.sim.rows.RowStepper)."""
        rows = importlib.import_module("stiction.sim.rows")
        return rows.RowStepper(self.integrator, self.substeps)

    def contact(self, params: Any, string: bool) -> ContactModel:
        return cast(
            ContactModel,
            self._contact_cls(params, self.integrator, substeps=self.substeps, string=string),
        )
