"""What goes in (a touch sample) and what comes out (the state at a tick)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

Phase = Literal["stick", "slip", "hover", "up"]


class Touch(NamedTuple):
    """One input sample in surface metres; any object with these attributes will do."""

    t: float
    x: float
    y: float
    tip: bool = True
    pressure: float | None = None


@dataclass(frozen=True, slots=True)
class ContactState:
    """The contact at a tick time: what the publisher turns into a frame."""

    t: float
    touch_x: float
    touch_y: float
    pointer_x: float
    pointer_y: float
    vx: float
    vy: float
    phase: Phase
    tension: float
    string_px: float
    string_dir: tuple[float, float]

    @property
    def energy_stretch(self) -> float:
        """|u - p|, the spring stretch in metres (handy for tests and plots)."""
        dx = self.touch_x - self.pointer_x
        dy = self.touch_y - self.pointer_y
        return float((dx * dx + dy * dy) ** 0.5)
