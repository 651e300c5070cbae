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
import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from stiction.drivers.sample import PenSample
from stiction.protocol import PASS_THROUGH, ContactWire, Phase, SceneWire
from stiction.scene.model import PRESSURE_LOAD, STICK_SLIP, STRING, Circle, Rect, Scene

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
    """Per-device contact state; survives scene changes.

    `tracks` maps a live contact id to its Track (naive pipeline) or to its
    slot in `slots` (batch pipeline); `slots` holds the batch pipeline's
    arrays, made on first use.
    """

    mapping: PixelMap
    tracks: dict[int, Any] = field(default_factory=dict)
    slots: Any = None


def _phase_of(s: PenSample) -> Phase:
    if not s.in_range:
        return "up"
    return "slip" if s.tip else "hover"


class NaivePipeline:
    """The per-contact pipeline: one ContactSim per contact, one Python pass per contact.

    The reference the batch `Pipeline` is held to (tests/scene, the scene
    benchmark's naive column): its results are the batch pipeline's, to
    1e-12 m. Also what `Pipeline` runs for a mapping that has no array form.
    """

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
                # Always the current scene's parameters: after set_params or
                # set_scene a contact already on a material follows the new
                # values too (ContactSim ignores the very object it has).
                switch = self.params[material]
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


# ------------------------------------------------------------------ batch
_PHASE_NAMES: tuple[Phase, ...] = ("stick", "slip", "hover", "up")
_MODE_TO_CODE = np.array([0, 1, 1, 2, 3], dtype=np.int8)
"""Simulator mode (stick, moving, resting, hover, up) -> index into _PHASE_NAMES."""
STICK_C, SLIP_C, HOVER_C, UP_C = 0, 1, 2, 3


@dataclass(slots=True)
class SampleArrays:
    """One tick's samples of one device as arrays, in time order.

    `pressure` is NaN where a sample has none (PenSample.pressure None).
    """

    contact: npt.NDArray[np.int64]
    t: npt.NDArray[np.float64]
    x: npt.NDArray[np.float64]
    y: npt.NDArray[np.float64]
    tip: npt.NDArray[np.bool_]
    in_range: npt.NDArray[np.bool_]
    pressure: npt.NDArray[np.float64]

    @classmethod
    def from_samples(cls, samples: Iterable[PenSample]) -> SampleArrays:
        ss = list(samples)
        return cls(
            np.fromiter((s.contact for s in ss), np.int64, len(ss)),
            np.fromiter((s.t for s in ss), np.float64, len(ss)),
            np.fromiter((s.x for s in ss), np.float64, len(ss)),
            np.fromiter((s.y for s in ss), np.float64, len(ss)),
            np.fromiter((s.tip for s in ss), np.bool_, len(ss)),
            np.fromiter((s.in_range for s in ss), np.bool_, len(ss)),
            np.fromiter(
                (math.nan if s.pressure is None else s.pressure for s in ss), np.float64, len(ss)
            ),
        )


class _Slots:
    """The batch pipeline's per-contact state of one device, one slot per live contact."""

    def __init__(self, stepper: Any, capacity: int = 16) -> None:
        self.stepper = stepper
        self.S = stepper.new_rows(capacity)
        self.id = np.zeros(capacity, dtype=np.int64)
        self.phase = np.full(capacity, UP_C, dtype=np.int8)
        self.has_sim = np.zeros(capacity, dtype=bool)
        self.material = np.full(capacity, -1, dtype=np.int64)
        """Index into `names` of the material the simulator is on (-1: none)."""
        self.names: tuple[str, ...] = ()
        self.lx = np.zeros(capacity)
        self.ly = np.zeros(capacity)
        self.lt = np.zeros(capacity)
        self.ltip = np.zeros(capacity, dtype=bool)
        self.lrange = np.zeros(capacity, dtype=bool)
        self.lpressure = np.full(capacity, math.nan)
        self.free = list(range(capacity - 1, -1, -1))
        self.order_ids = np.zeros(0, dtype=np.int64)
        """Live contact ids, ascending, and their slots: the output order."""
        self.order_slots = np.zeros(0, dtype=np.int64)

    def grow(self) -> None:
        old = self.id.shape[0]
        new = 2 * old
        self.S = np.concatenate([self.S, self.stepper.new_rows(old)])
        for name in ("id", "phase", "has_sim", "material", "lx", "ly", "lt", "ltip", "lrange"):
            arr = getattr(self, name)
            setattr(self, name, np.concatenate([arr, np.zeros_like(arr)]))
        self.lpressure = np.concatenate([self.lpressure, np.full(old, math.nan)])
        self.free.extend(range(new - 1, old - 1, -1))

    def reorder(self, tracks: dict[int, Any]) -> None:
        ids = np.fromiter(tracks.keys(), np.int64, len(tracks))
        slots = np.fromiter(tracks.values(), np.int64, len(tracks))
        order = np.argsort(ids, kind="stable")
        self.order_ids = ids[order]
        self.order_slots = slots[order]


@dataclass(slots=True)
class ContactArrays:
    """One device's contacts at a tick, as arrays in id order (`Pipeline.step_arrays`)."""

    pipeline: Pipeline
    id: npt.NDArray[np.int64]
    phase: npt.NDArray[np.int8]
    """Index into ("stick", "slip", "hover", "up")."""
    touch: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
    pointer: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
    touch_px: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
    pointer_px: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
    tension: npt.NDArray[np.float64]
    material: npt.NDArray[np.int64]
    """Index into `pipeline.names`; -1 is pass-through."""
    string: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]] | None
    pressure: npt.NDArray[np.float64] | None
    load_gain: npt.NDArray[np.float64] | None

    def wire(self) -> list[ContactWire]:
        """The contacts as the protocol's dictionaries (what `Pipeline.step` returns)."""
        names = self.pipeline.names
        cols = [
            self.id.tolist(),
            self.phase.tolist(),
            self.touch[0].tolist(),
            self.touch[1].tolist(),
            self.pointer[0].tolist(),
            self.pointer[1].tolist(),
            self.touch_px[0].tolist(),
            self.touch_px[1].tolist(),
            self.pointer_px[0].tolist(),
            self.pointer_px[1].tolist(),
            self.tension.tolist(),
            self.material.tolist(),
        ]
        out: list[ContactWire] = []
        for cid, ph, tx, ty, px, py, tpx, tpy, ppx, ppy, ten, mat in zip(*cols, strict=True):
            c: ContactWire = {
                "id": cid,
                "phase": _PHASE_NAMES[ph],
                "touch_m": [tx, ty],
                "pointer_m": [px, py],
                "touch_px": [tpx, tpy],
                "pointer_px": [ppx, ppy],
                "tension": ten,
                "material": names[mat] if mat >= 0 else PASS_THROUGH,
            }
            out.append(c)
        if self.string is not None:
            length, dx, dy = (a.tolist() for a in self.string)
            for c, ln, a, b in zip(out, length, dx, dy, strict=True):
                c["string"] = {"length_px": ln, "dir": [a, b]}
        if self.pressure is not None and self.load_gain is not None:
            for c, p, g in zip(out, self.pressure.tolist(), self.load_gain.tolist(), strict=True):
                wire: dict[str, Any] = c  # type: ignore[assignment]
                wire["pressure"] = None if math.isnan(p) else p
                wire["load_gain"] = g
        return out


_SERIAL = itertools.count(1)


class Pipeline:
    """One scene, compiled, stepping every contact of a device in one batch per tick.

    Per tick: the samples are grouped by contact with one sort; the material
    under every contact is found with array tests per region; every contact
    with friction advances in one call of the row stepper (compiled with
    numba when installed); pass-through contacts are copied as arrays; and
    only the fields the scene's effects produce are computed. The results
    are those of `NaivePipeline` (tests/scene/test_scene_batch.py).

    Each contact's row holds its material's parameters, tagged with this
    pipeline's serial; a row holding another tag (an earlier scene, or
    parameters changed by set_params) takes this pipeline's values at the
    next tick, so changes apply to contacts already on a material.
    """

    def __init__(
        self,
        scene: Scene,
        backend: SimBackend,
        defaults: Mapping[str, float],
    ) -> None:
        self._naive = NaivePipeline(scene, backend, defaults)
        self.scene = scene
        self.backend = backend
        self.defaults = self._naive.defaults
        self.friction = self._naive.friction
        self.string = self._naive.string
        self.pressure = self._naive.pressure
        self.resolved = self._naive.resolved
        self.params = self._naive.params
        self.frictionless = self._naive.frictionless
        self.names: tuple[str, ...] = tuple(scene.materials)
        self.serial = next(_SERIAL)
        self._stepper: Any = None
        self._rows: npt.NDArray[np.float64] | None = None
        """Row i holds names[i]'s parameters; row len(names) + i the frictionless ones."""
        outside = scene.outside
        self._outside = self.names.index(outside) if outside in self.names else -1
        self._regions = [
            (self.names.index(r.material) if r.material in self.names else -1, r.shape)
            for r in scene.regions
        ]

    def wire(self) -> SceneWire:
        return self._naive.wire()

    # ------------------------------------------------------------ set-up
    def _stepper_rows(self) -> tuple[Any, npt.NDArray[np.float64]]:
        if self._rows is None:
            rows_of: Any = getattr(self.backend, "rows", None)
            if rows_of is None:
                raise TypeError("this backend has no row stepper; use NaivePipeline")
            stepper = rows_of()
            n = len(self.names)
            table = stepper.new_rows(max(2 * n, 1))
            for i, name in enumerate(self.names):
                table[i] = stepper.param_row(self.params[name])
                table[n + i] = stepper.param_row(self.frictionless[name])
            table[:, stepper.PID] = self.serial * 65536 + np.arange(table.shape[0])
            self._stepper, self._rows = stepper, table
        return self._stepper, self._rows

    def _slots(self, dev: DeviceRun) -> _Slots:
        stepper, _ = self._stepper_rows()
        slots: _Slots | None = dev.slots
        if slots is None:
            slots = dev.slots = _Slots(stepper)
            slots.names = self.names
        elif slots.names != self.names:
            # Another scene: its material indices become this scene's.
            remap = np.array([self.names.index(n) if n in self.names else -1 for n in slots.names])
            remap = np.append(remap, -1)  # index -1 stays -1
            slots.material = remap[slots.material]
            slots.names = self.names
        return slots

    # -------------------------------------------------------------- step
    def step(
        self, dev: DeviceRun, t: float, prev_t: float, samples: Iterable[PenSample]
    ) -> list[ContactWire]:
        """Advance every contact of one device to tick time `t` (see NaivePipeline.step)."""
        if getattr(dev.mapping, "to_px_array", None) is None:
            return self._naive.step(dev, t, prev_t, samples)
        return self.step_arrays(dev, t, prev_t, SampleArrays.from_samples(samples)).wire()

    def end_all(self, dev: DeviceRun) -> list[ContactWire]:
        """End every contact of a device that went away: each reported once as "up"."""
        slots: _Slots | None = dev.slots
        if slots is None or getattr(dev.mapping, "to_px_array", None) is None:
            return self._naive.end_all(dev)
        out: list[ContactWire] = []
        for cid in sorted(dev.tracks):
            i = dev.tracks[cid]
            x, y = float(slots.lx[i]), float(slots.ly[i])
            tpx = dev.mapping.to_px(cid, x, y)
            c: ContactWire = {
                "id": cid,
                "phase": "up",
                "touch_m": [x, y],
                "pointer_m": [x, y],
                "touch_px": [tpx[0], tpx[1]],
                "pointer_px": [tpx[0], tpx[1]],
                "tension": 0.0,
                "material": PASS_THROUGH,
            }
            if self.pressure:
                p = float(slots.lpressure[i])
                wire: dict[str, Any] = c  # type: ignore[assignment]
                wire["pressure"] = None if math.isnan(p) else p
                wire["load_gain"] = self.scene.pressure_load.gain(wire["pressure"])
            out.append(c)
            dev.mapping.end(cid)
            slots.free.append(i)
        dev.tracks.clear()
        slots.reorder(dev.tracks)
        return out

    def step_arrays(
        self, dev: DeviceRun, t: float, prev_t: float, s: SampleArrays
    ) -> ContactArrays:
        """Advance every contact of one device to `t`; the result as arrays."""
        slots = self._slots(dev)
        stepper, table = self._stepper_rows()
        mapping: Any = dev.mapping
        # Group the samples by contact (stable: each contact's stay in time order).
        order = np.argsort(s.contact, kind="stable")
        cs = s.contact[order]
        st, sx, sy = s.t[order], s.x[order], s.y[order]
        stip, srange, spress = s.tip[order], s.in_range[order], s.pressure[order]
        uniq, first, count = np.unique(cs, return_index=True, return_counts=True)
        # New contacts: a slot each, the first sample as their last one.
        known = dev.tracks
        if uniq.size:
            pos = np.searchsorted(slots.order_ids, uniq)
            pos_c = np.minimum(pos, max(slots.order_ids.size - 1, 0))
            found = (pos < slots.order_ids.size) & (
                slots.order_ids[pos_c] == uniq if slots.order_ids.size else False
            )
            if not np.all(found):
                for u in np.nonzero(~found)[0].tolist():
                    cid = int(uniq[u])
                    if not slots.free:
                        slots.grow()
                    i = slots.free.pop()
                    known[cid] = i
                    k = int(first[u])
                    slots.S[i] = stepper.new_rows(1)[0]
                    slots.id[i] = cid
                    slots.phase[i] = UP_C
                    slots.has_sim[i] = False
                    slots.material[i] = -1
                    slots.lx[i], slots.ly[i], slots.lt[i] = sx[k], sy[k], st[k]
                    slots.ltip[i], slots.lrange[i], slots.lpressure[i] = (
                        stip[k],
                        srange[k],
                        spress[k],
                    )
                    mapping.begin(cid, float(sx[k]), float(sy[k]))
                slots.reorder(known)
        ids = slots.order_ids
        sl = slots.order_slots
        n = ids.size
        # Each live contact's sample range [firsts, ends) in the sorted arrays.
        firsts = np.zeros(n, dtype=np.int64)
        ends = np.zeros(n, dtype=np.int64)
        if uniq.size:
            at = np.searchsorted(ids, uniq)
            firsts[at] = first
            ends[at] = first + count
        touching = slots.phase[sl] <= SLIP_C
        held_x, held_y, held_tip = slots.lx[sl], slots.ly[sl], slots.ltip[sl]
        has = ends > firsts
        if uniq.size:
            li = ends[has] - 1
            hs = sl[has]
            slots.lx[hs], slots.ly[hs], slots.lt[hs] = sx[li], sy[li], st[li]
            slots.ltip[hs], slots.lrange[hs], slots.lpressure[hs] = stip[li], srange[li], spress[li]
        lx, ly = slots.lx[sl], slots.ly[sl]
        ltip, lrange = slots.ltip[sl], slots.lrange[sl]
        S = slots.S
        phase = np.where(~lrange, UP_C, np.where(ltip, SLIP_C, HOVER_C)).astype(np.int8)
        tx, ty = lx.copy(), ly.copy()
        px, py = lx.copy(), ly.copy()
        tension = np.zeros(n)
        material = np.full(n, -1, dtype=np.int64)
        slen = sdx = sdy = None
        if self.string:
            slen, sdx, sdy = np.zeros(n), np.zeros(n), np.zeros(n)
        pressure = load = None
        if self.pressure:
            pressure = slots.lpressure[sl]
            load = self._gains(pressure)
        if not self.friction:
            if not self.scene.regions:
                material[:] = self._outside
            else:
                qx, qy = mapping.to_px_array(lx, ly)
                material = self._material_at(qx, qy)
        else:
            has_sim = slots.has_sim[sl]
            use_ptr = touching & has_sim
            mx = np.where(use_ptr, S[sl, stepper.PX], lx)
            my = np.where(use_ptr, S[sl, stepper.PY], ly)
            qx, qy = mapping.to_px_array(mx, my)
            mat = self._material_at(qx, qy)
            fric = mat >= 0
            nm = len(self.names)
            old = slots.material[sl]
            glide = ~fric & has_sim & touching & (old >= 0)
            # Rows entering friction now: fresh, on their material, at their load.
            new = fric & ~has_sim
            loads = load if load is not None else np.ones(n)
            if new.any():
                for j in np.nonzero(new)[0].tolist():
                    i = int(sl[j])
                    S[i] = stepper.new_rows(1)[0]
                    S[i, stepper.LOAD] = loads[j]
                    stepper.loops.copy_params(S, np.array([i], dtype=np.int64), table[mat[j]])
                    if touching[j] and held_tip[j]:
                        # Entering friction mid-stroke: the contact starts where
                        # the touch was held at the previous tick.
                        stepper.touch_down(S[i], float(held_x[j]), float(held_y[j]), prev_t)
            want = np.where(fric, mat, np.where(glide, nm + old, -1))
            adv = want >= 0
            rows = sl[adv]
            wanted = want[adv]
            # Rows holding other parameters (another material, an earlier
            # scene, parameters since changed) take this pipeline's.
            stale = S[rows, stepper.PID] != table[wanted, stepper.PID]
            if stale.any():
                for v in np.unique(wanted[stale]).tolist():
                    pick = np.ascontiguousarray(rows[stale & (wanted == v)])
                    stepper.loops.copy_params(S, pick, table[v])
            stepper.loops.advance_tracks(
                S,
                np.ascontiguousarray(rows),
                np.ascontiguousarray(firsts[adv]),
                np.ascontiguousarray(ends[adv]),
                st,
                sx,
                sy,
                stip,
                srange,
                np.ascontiguousarray(loads[adv]),
                t,
            )
            R = S[rows]
            mode = R[:, stepper.MODE].astype(np.int64)
            rph = _MODE_TO_CODE[mode]
            rux, ruy = R[:, stepper.UX], R[:, stepper.UY]
            on = mode < stepper.HOVER
            rpx = np.where(on, R[:, stepper.PX], rux)
            rpy = np.where(on, R[:, stepper.PY], ruy)
            ex, ey = rux - rpx, ruy - rpy
            d = np.sqrt(ex * ex + ey * ey)
            ten = np.where(on, R[:, stepper.K] * d, 0.0)
            # A glide that has settled (or ended) is dropped: the contact passes through.
            gl = glide[adv]
            keep = ~gl | (on & ~(np.hypot(ex, ey) < SETTLE_DISTANCE_M))
            ai = np.nonzero(adv)[0]
            ki = ai[keep]
            phase[ki] = rph[keep]
            tx[ki], ty[ki] = rux[keep], ruy[keep]
            px[ki], py[ki] = rpx[keep], rpy[keep]
            tension[ki] = ten[keep]
            material[ki] = np.where(gl[keep], -1, mat[ki])
            if slen is not None and sdx is not None and sdy is not None:
                pos_d = on & (d > 0.0)
                with np.errstate(invalid="ignore", divide="ignore"):
                    ln = np.where(pos_d, R[:, stepper.CL] * np.sqrt(ten), 0.0)
                    ux_ = np.where(pos_d, ex / d, 0.0)
                    uy_ = np.where(pos_d, ey / d, 0.0)
                slen[ki], sdx[ki], sdy[ki] = ln[keep], ux_[keep], uy_[keep]
            # Who holds a simulator after this tick, and on what.
            sim_after = np.zeros(n, dtype=bool)
            sim_after[ki] = True
            slots.has_sim[sl] = sim_after
            slots.material[sl] = np.where(fric, mat, np.where(sim_after, old, -1))
        slots.phase[sl] = phase
        tpx = mapping.to_px_array(tx, ty)
        ppx = mapping.to_px_array(px, py)
        out = ContactArrays(
            self,
            ids.copy(),
            phase,
            (tx, ty),
            (px, py),
            tpx,
            ppx,
            tension,
            material,
            (slen, sdx, sdy) if slen is not None and sdx is not None and sdy is not None else None,
            pressure,
            load,
        )
        ended = phase == UP_C
        if ended.any():
            for j in np.nonzero(ended)[0].tolist():
                cid = int(ids[j])
                i = known.pop(cid)
                slots.free.append(i)
                slots.has_sim[i] = False
                mapping.end(cid)
            slots.reorder(known)
        return out

    # ----------------------------------------------------------- geometry
    def _material_at(
        self, qx: npt.NDArray[np.float64], qy: npt.NDArray[np.float64]
    ) -> npt.NDArray[np.int64]:
        """Scene.material_at for arrays of display points (the topmost region wins)."""
        out = np.full(qx.shape, self._outside, dtype=np.int64)
        for mat, shape in self._regions:
            out[_contains(shape, qx, qy)] = mat
        return out

    def _gains(self, p: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """PressureLoad.gain over arrays (1.0 where a sample has no pressure)."""
        pl = self.scene.pressure_load
        ok = np.isfinite(p)
        q = np.clip(np.where(ok, p, 0.0), 0.0, 1.0)
        g = pl.min_gain + (pl.max_gain - pl.min_gain) * np.power(q, pl.exponent)
        return np.where(ok, g, 1.0)


def _contains(shape: Any, px: npt.NDArray[np.float64], py: npt.NDArray[np.float64]) -> Any:
    """shape.contains over arrays, with the same comparisons."""
    if isinstance(shape, Rect):
        return (
            (shape.x <= px)
            & (px <= shape.x + shape.w)
            & (shape.y <= py)
            & (py <= shape.y + shape.h)
        )
    if isinstance(shape, Circle):
        dx = px - shape.cx
        dy = py - shape.cy
        return dx * dx + dy * dy <= shape.r * shape.r
    x0, y0, x1, y1 = shape.bbox
    inside = np.zeros(px.shape, dtype=bool)
    box = ~((px < x0) | (px > x1) | (py < y0) | (py > y1))
    pts = shape.points
    j = len(pts) - 1
    with np.errstate(invalid="ignore", divide="ignore"):
        for i in range(len(pts)):
            xi, yi = pts[i]
            xj, yj = pts[j]
            if yj != yi:
                cross = ((yi > py) != (yj > py)) & (px < (xj - xi) * (py - yi) / (yj - yi) + xi)
                inside ^= cross
            j = i
    return inside & box
