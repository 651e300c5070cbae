"""One stimulus: the scene the daemon runs for it, and when it begins and ends in the frames.

The scene is one material over the whole display (outside = the material),
so the pointer feels the same surface wherever the pen lands; the string
condition is the scene's ``string`` effect, which also decides whether frames
carry the string at all (a renderer cannot draw what it is not sent).

A stimulus begins when the pen touches down within `start_tolerance_px` of
the display centre (where the page draws the dot) and ends when the pointer
has moved `travel_px` from where it began (User study 1, Task design). The
touch-down must be a fresh one (the pen seen off the surface after the
stimulus was armed), so a pen still down from the previous stimulus never
starts the next. A pen lifted before the end restarts the stimulus: what the
participant saw was not the whole stimulus.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from stiction.experiment.study import Study

TOUCHING = ("stick", "slip")


def scene_toml(study: Study, mu_s: float, string: bool) -> str:
    """The scene of one stimulus (docs/scenes.md); the name hides the condition."""
    p = study.params
    effects = '["stick_slip", "string"]' if string else '["stick_slip"]'
    return (
        "[scene]\n"
        'name = "experiment"\n'
        f"display = [{study.display[0]}, {study.display[1]}]\n"
        f"effects = {effects}\n"
        'outside = "surface"\n\n'
        "[materials.surface]\n"
        f"mu_s = {mu_s!r}\nmu_k = {p['mu_k']!r}\nk = {p['k']!r}\nm = {p['m']!r}\n"
        f"C_l = {p['C_l']!r}\n"
    )


@dataclass
class StimulusMonitor:
    """Watches one device's frames for the stimulus's start and end and measures it."""

    centre: tuple[float, float]
    tolerance: float
    travel: float
    record: bool = False
    lifted: bool = False
    started: bool = False
    ended: bool = False
    restarts: int = 0
    origin: tuple[float, float] = (0.0, 0.0)
    t0: float = 0.0
    t_last: float = 0.0
    stick_s: float = 0.0
    max_string: float | None = None
    max_gap: float = 0.0
    path_px: float = 0.0
    last_touch: tuple[float, float] | None = None
    frames: list[dict[str, Any]] = field(default_factory=list)

    def _reset(self) -> None:
        self.started = False
        self.stick_s = self.path_px = self.max_gap = 0.0
        self.max_string = None
        self.last_touch = None
        self.frames = []

    def feed(self, frame: dict[str, Any]) -> bool:
        """Take one frame; True once the stimulus has ended."""
        if self.ended:
            return True
        contacts = frame.get("contacts") or []
        c = contacts[0] if contacts else None
        touching = c is not None and c.get("phase") in TOUCHING
        t = float(frame.get("t", 0.0))
        if not self.started:
            if not touching or c is None:
                self.lifted = True
                return False
            if not self.lifted:
                return False
            px, py = c["pointer_px"]
            if math.hypot(px - self.centre[0], py - self.centre[1]) > self.tolerance:
                return False
            self.started, self.origin, self.t0, self.t_last = True, (px, py), t, t
        elif not touching or c is None:
            self.restarts += 1
            self._reset()
            self.lifted = True
            return False
        dt = t - self.t_last
        self.t_last = t
        if c["phase"] == "stick":
            self.stick_s += dt
        touch = (float(c["touch_px"][0]), float(c["touch_px"][1]))
        pointer = (float(c["pointer_px"][0]), float(c["pointer_px"][1]))
        if self.last_touch is not None:
            self.path_px += math.dist(touch, self.last_touch)
        self.last_touch = touch
        self.max_gap = max(self.max_gap, math.dist(touch, pointer))
        s = c.get("string")
        if s is not None:
            self.max_string = max(self.max_string or 0.0, float(s.get("length_px", 0.0)))
        if self.record:
            self.frames.append(frame)
        if math.dist(pointer, self.origin) >= self.travel:
            self.ended = True
        return self.ended

    def measures(self) -> dict[str, float | None]:
        duration = self.t_last - self.t0
        return {
            "stick_duration_s": self.stick_s,
            "max_string_length_px": self.max_string,
            "max_pointer_touch_px": self.max_gap,
            "stroke_speed_px_s": self.path_px / duration if duration > 0 else 0.0,
        }
