"""A scene compiled into the per-tick work it needs, and nothing more.

The daemon hands every device's samples for one tick to `Pipeline.step`; the
pipeline decides per contact which material lies under the virtual pen, runs
the friction simulation only where a material applies, and builds the wire
contacts with only the fields the scene's effects produce. A contact over a
pass-through area holds no simulator and costs a copy; the string is computed
only when the scene has the ``string`` effect.

The simulator is reached through `SimBackend` (stiction.scene.backend wires
the real one), so this module never imports the simulator's internals and a
test can substitute a recorder.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from stiction.drivers.sample import PenSample
from stiction.protocol import PASS_THROUGH, ContactWire, Phase, SceneWire
from stiction.scene.model import PRESSURE_LOAD, STICK_SLIP, STRING, Scene

SETTLE_DISTANCE_M = 1e-6
"""A pen leaving friction for a pass-through area is simulated without friction
until it is this close to the touch point, so the pointer glides back instead
of jumping; then its simulator is dropped."""


class ContactStateLike(Protocol):
    """The part of stiction.sim.ContactState the pipeline reads."""

    @property
    def touch_x(self) -> float: ...
    @property
    def touch_y(self) -> float: ...
    @property
    def pointer_x(self) -> float: ...
    @property
    def pointer_y(self) -> float: ...
    @property
    def vx(self) -> float: ...
    @property
    def vy(self) -> float: ...
    @property
    def phase(self) -> str: ...
    @property
    def tension(self) -> float: ...
    @property
    def string_px(self) -> float: ...
    @property
    def string_dir(self) -> tuple[float, float]: ...


class ContactModel(Protocol):
    """stiction.sim.ContactSim as the pipeline uses it."""

    def advance(
        self, t: float, samples: Sequence[Any], *, params: Any = None, load_gain: float = 1.0
    ) -> ContactStateLike: ...


class SimBackend(Protocol):
    """Makes validated parameter sets and contact simulators."""

    def params(self, values: Mapping[str, float]) -> Any:
        """Validated parameters (raises stiction.errors.ParamError)."""
        ...

    def contact(self, params: Any, string: bool) -> ContactModel: ...


class PixelMap(Protocol):
    """Surface metres -> display pixels for one device (stiction.daemon.mapping)."""

    def begin(self, contact: int, x: float, y: float) -> None: ...
    def to_px(self, contact: int, x: float, y: float) -> tuple[float, float]: ...
    def end(self, contact: int) -> None: ...


@dataclass(slots=True)
class Track:
    """What the pipeline remembers about one live contact between ticks."""

    id: int
    last: PenSample
    sim: ContactModel | None = None
    material: str | None = None
    phase: str = "up"
    pointer: tuple[float, float] = (0.0, 0.0)


@dataclass(slots=True)
class DeviceRun:
    """Per-device contact state; survives scene changes."""

    mapping: PixelMap
    tracks: dict[int, Track] = field(default_factory=dict)


def _phase_of(s: PenSample) -> Phase:
    if not s.in_range:
        return "up"
    return "slip" if s.tip else "hover"


class Pipeline:
    """One scene, compiled: resolved material parameters and the stages it needs."""

    def __init__(
        self,
        scene: Scene,
        backend: SimBackend,
        defaults: Mapping[str, float],
    ) -> None:
        self.scene = scene
        self.backend = backend
        self.defaults = dict(defaults)
        self.friction = STICK_SLIP in scene.effects
        self.string = STRING in scene.effects
        self.pressure = PRESSURE_LOAD in scene.effects
        self.resolved: dict[str, dict[str, float]] = {}
        self.params: dict[str, Any] = {}
        self.frictionless: dict[str, Any] = {}
        for name, material in scene.materials.items():
            values = {**self.defaults, **material.overrides()}
            self.resolved[name] = values
            self.params[name] = backend.params(values)
            self.frictionless[name] = backend.params({**values, "mu_s": 0.0, "mu_k": 0.0})

    def wire(self) -> SceneWire:
        return self.scene.wire(self.resolved)

    def material_under(self, dev: DeviceRun, track: Track, touching: bool) -> str | None:
        """The material under the virtual pen (the touch point for a new touch)."""
        x, y = track.pointer if touching else (track.last.x, track.last.y)
        px, py = dev.mapping.to_px(track.id, x, y)
        return self.scene.material_at(px, py)

    def step(
        self, dev: DeviceRun, t: float, prev_t: float, samples: Iterable[PenSample]
    ) -> list[ContactWire]:
        """Advance every contact of one device to tick time `t`.

        `samples` are this device's samples with prev_t < s.t <= t on the loop
        clock, in time order. Contacts are reported in id order; a contact that
        ended is reported once with phase "up" and then forgotten.
        """
        groups: dict[int, list[PenSample]] = {}
        for s in samples:
            groups.setdefault(s.contact, []).append(s)
        out: list[ContactWire] = []
        for cid in sorted(groups.keys() | dev.tracks.keys()):
            ss = groups.get(cid, [])
            track = dev.tracks.get(cid)
            if track is None:
                if not ss:
                    continue
                track = Track(id=cid, last=ss[0])
                dev.tracks[cid] = track
                dev.mapping.begin(cid, ss[0].x, ss[0].y)
            out.append(self._advance(dev, track, t, prev_t, ss))
            if track.phase == "up":
                del dev.tracks[cid]
                dev.mapping.end(cid)
        return out

    def end_all(self, dev: DeviceRun) -> list[ContactWire]:
        """End every contact of a device that went away: each reported once as "up"."""
        out: list[ContactWire] = []
        for cid in sorted(dev.tracks):
            track = dev.tracks[cid]
            track.phase = "up"
            x, y = track.last.x, track.last.y
            out.append(self._wire(dev, track, "up", (x, y), (x, y), 0.0, None, track.last))
            dev.mapping.end(cid)
        dev.tracks.clear()
        return out

    def _advance(
        self, dev: DeviceRun, track: Track, t: float, prev_t: float, ss: list[PenSample]
    ) -> ContactWire:
        touching = track.phase in ("stick", "slip")
        held = track.last
        if ss:
            track.last = ss[-1]
        if not self.friction:
            return self._pass(dev, track, self._material_name(dev, track, touching))
        material = self.material_under(dev, track, touching and track.sim is not None)
        load_gain = self.scene.pressure_load.gain(track.last.pressure) if self.pressure else 1.0
        if material is not None and material in self.params:
            if track.sim is None:
                track.sim = self.backend.contact(self.params[material], self.string)
                if touching and held.tip:
                    # Entering friction mid-stroke: the new simulator starts its
                    # contact where the touch was held at the previous tick.
                    ss = [dataclasses.replace(held, t=prev_t), *ss]
                switch = None
            else:
                switch = self.params[material] if material != track.material else None
            track.material = material
            state = track.sim.advance(t, ss, params=switch, load_gain=load_gain)
            return self._from_state(dev, track, state, material)
        if track.sim is not None and touching:
            # Leaving friction: glide back to the touch without friction, then drop.
            frictionless = self.frictionless.get(track.material or "")
            if frictionless is not None:
                state = track.sim.advance(t, ss, params=frictionless, load_gain=load_gain)
                if state.phase in ("stick", "slip") and not self._settled(state):
                    return self._from_state(dev, track, state, PASS_THROUGH)
        track.sim = None
        track.material = None
        return self._pass(dev, track, PASS_THROUGH)

    @staticmethod
    def _settled(state: ContactStateLike) -> bool:
        d = math.hypot(state.touch_x - state.pointer_x, state.touch_y - state.pointer_y)
        return d < SETTLE_DISTANCE_M

    def _material_name(self, dev: DeviceRun, track: Track, touching: bool) -> str:
        if not self.scene.regions:
            return self.scene.outside or PASS_THROUGH
        return self.material_under(dev, track, False) or PASS_THROUGH

    def _pass(self, dev: DeviceRun, track: Track, material: str) -> ContactWire:
        s = track.last
        phase = _phase_of(s)
        track.phase = phase
        track.pointer = (s.x, s.y)
        string = (0.0, (0.0, 0.0)) if self.string else None
        return self._wire(dev, track, phase, (s.x, s.y), (s.x, s.y), 0.0, string, s, material)

    def _from_state(
        self, dev: DeviceRun, track: Track, st: ContactStateLike, material: str
    ) -> ContactWire:
        phase = st.phase
        track.phase = phase
        track.pointer = (st.pointer_x, st.pointer_y)
        string = (st.string_px, st.string_dir) if self.string else None
        return self._wire(
            dev,
            track,
            phase,  # type: ignore[arg-type]
            (st.touch_x, st.touch_y),
            (st.pointer_x, st.pointer_y),
            st.tension,
            string,
            track.last,
            material,
        )

    def _wire(
        self,
        dev: DeviceRun,
        track: Track,
        phase: Phase,
        touch: tuple[float, float],
        pointer: tuple[float, float],
        tension: float,
        string: tuple[float, tuple[float, float]] | None,
        sample: PenSample,
        material: str | None = None,
    ) -> ContactWire:
        to_px = dev.mapping.to_px
        tpx = to_px(track.id, touch[0], touch[1])
        ppx = tpx if pointer == touch else to_px(track.id, pointer[0], pointer[1])
        c: ContactWire = {
            "id": track.id,
            "phase": phase,
            "touch_m": [touch[0], touch[1]],
            "pointer_m": [pointer[0], pointer[1]],
            "touch_px": [tpx[0], tpx[1]],
            "pointer_px": [ppx[0], ppx[1]],
            "tension": tension,
            "material": material if material is not None else PASS_THROUGH,
        }
        if string is not None:
            length, (dx, dy) = string
            c["string"] = {"length_px": length, "dir": [dx, dy]}
        if self.pressure:
            wire: dict[str, Any] = c  # type: ignore[assignment]
            wire["pressure"] = sample.pressure
            wire["load_gain"] = self.scene.pressure_load.gain(sample.pressure)
        return c
