"""A scene compiled into the per-tick work it needs, and nothing more.

The daemon hands every device's samples for one tick to `Pipeline.step`; the
pipeline decides per contact which material lies under the virtual pen, runs
the friction simulation only where a material applies, and builds the wire
contacts with only the fields the scene's effects produce. `Pipeline` does
this for all contacts of a device in one compiled call (scene/tick.py, one
simulator row per contact); `NaivePipeline`, one ContactSim and one Python
pass per contact, is the reference it is tested and benchmarked against.

The simulator is reached through `SimBackend` (stiction.scene.backend wires
the real one), so this module never imports the simulator's internals and a
test can substitute a recorder.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
import threading
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from stiction.drivers.sample import PenSample
from stiction.protocol import PASS_THROUGH, ContactWire, Phase, SceneWire
from stiction.scene import tick
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
        """The arrays of a tick's samples.

        Filled one sample at a time into empty arrays: a live tick has a few
        samples, and for those this costs a third of seven np.fromiter
        passes (1.8 us against 5.2 us for two samples, 4.0 against 7.4 for
        ten, about even at fifty; timeit on the development VM). It runs
        after the deadline in every tick that was not prepared."""
        ss = samples if isinstance(samples, list) else list(samples)
        n = len(ss)
        contact = np.empty(n, np.int64)
        t = np.empty(n)
        x = np.empty(n)
        y = np.empty(n)
        tip = np.empty(n, np.bool_)
        in_range = np.empty(n, np.bool_)
        pressure = np.empty(n)
        for i, s in enumerate(ss):
            contact[i] = s.contact
            t[i] = s.t
            x[i] = s.x
            y[i] = s.y
            tip[i] = s.tip
            in_range[i] = s.in_range
            pressure[i] = math.nan if s.pressure is None else s.pressure
        return cls(contact, t, x, y, tip, in_range, pressure)


class _Slots:
    """The batch pipeline's state of one device: a simulator row and an L row per live contact."""

    def __init__(self, stepper: Any, capacity: int = 16) -> None:
        self.stepper = stepper
        self.S = stepper.new_rows(capacity)
        self.L = np.zeros((capacity, tick.LCOLS))
        self.L[:, tick.LPHASE] = tick.UP_C
        self.L[:, tick.LMAT] = -1
        self.names: tuple[str, ...] = ()
        self.free = list(range(capacity - 1, -1, -1))
        self.order_ids = np.zeros(0, dtype=np.int64)
        """Live contact ids, ascending, and their slots: the output order."""
        self.order_slots = np.zeros(0, dtype=np.int64)
        self.pos_of = np.full(64, -1, dtype=np.int64)
        self.iw = np.zeros((3, 0), dtype=np.int64)
        self.fw = np.zeros((4, 0))
        self.bw = np.zeros((2, 0), dtype=np.bool_)
        """The compiled tick's scratch space (it allocates nothing itself)."""
        self.aff_key: tuple[float, ...] = ()
        self.aff = np.zeros(6)

    def affine(self, coefficients: tuple[float, ...]) -> npt.NDArray[np.float64]:
        """The mapping's affine coefficients as the array the tick takes (made once per change)."""
        if coefficients != self.aff_key:
            self.aff_key = coefficients
            self.aff = np.array(coefficients, dtype=np.float64)
        return self.aff

    def scratch(self, samples: int, contacts: int) -> tuple[Any, Any, Any]:
        """Scratch rows long enough for a tick of `samples` samples over `contacts` contacts."""
        need = tick.scratch_size(samples, contacts)
        if self.iw.shape[1] < need:
            size = max(need, 2 * self.iw.shape[1], 64)
            self.iw = np.zeros((3, size), dtype=np.int64)
            self.fw = np.zeros((4, size))
            self.bw = np.zeros((2, size), dtype=np.bool_)
        return self.iw, self.fw, self.bw

    def copy(self) -> _Slots:
        """A copy whose stepping leaves this one as it is (Pipeline.fork).

        The contact rows and the free list are copied. The rest is shared:
        the order tables are only read by the compiled tick and replaced,
        never written, by `reorder`; the tick writes the scratch space and
        reads it back within one call; the affine array is replaced, never
        written. (Copying the order tables too made the copy, the first
        thing the daemon's preparation does after its sleep, cost 72 us at
        p50 with cold caches.)"""
        twin = copy.copy(self)
        twin.S = self.S.copy()
        twin.L = self.L.copy()
        twin.free = self.free.copy()
        return twin

    def grow(self) -> None:
        old = self.L.shape[0]
        self.S = np.concatenate([self.S, self.stepper.new_rows(old)])
        self.L = np.concatenate([self.L, self.L[:old] * 0.0])
        self.free.extend(range(2 * old - 1, old - 1, -1))

    def reorder(self, tracks: dict[int, Any]) -> None:
        ids = np.fromiter(tracks.keys(), np.int64, len(tracks))
        slots = np.fromiter(tracks.values(), np.int64, len(tracks))
        order = np.argsort(ids, kind="stable")
        self.order_ids = ids[order]
        self.order_slots = slots[order]
        # A direct table for the usual small ids (slot numbers, tracking ids).
        small = self.order_ids[(self.order_ids >= 0) & (self.order_ids < DENSE_IDS)]
        size = int(small.max()) + 1 if small.size else 0
        # A new table, never the old one rewritten: a copy (`copy`) shares it.
        grown = 2 * self.pos_of.shape[0] if self.pos_of.shape[0] < size else 0
        pos_of = np.full(max(size, grown, self.pos_of.shape[0]), -1, dtype=np.int64)
        pos_of[small] = np.nonzero((self.order_ids >= 0) & (self.order_ids < DENSE_IDS))[0]
        self.pos_of = pos_of


@dataclass(slots=True)
class ContactArrays:
    """One device's contacts at a tick, in id order (`Pipeline.step_arrays`).

    `values` has one row per contact and the columns of stiction.scene.tick
    (OPHASE: index into ("stick", "slip", "hover", "up"); OMAT: index into
    `names`, -1 for pass-through; touch, pointer and their pixels; tension;
    string length and direction; pressure and load gain).
    """

    ids: npt.NDArray[np.int64]
    values: npt.NDArray[np.float64]
    names: tuple[str, ...]
    string: bool
    pressure: bool

    def wire(self) -> list[ContactWire]:
        """The contacts as the protocol's dictionaries (what `Pipeline.step` returns)."""
        names = self.names
        out: list[ContactWire] = []
        for cid, row in zip(self.ids.tolist(), self.values.tolist(), strict=True):
            (ph, tx, ty, px, py, tpx, tpy, ppx, ppy, ten, mat, ln, dx, dy, pr, lg) = row
            mi = int(mat)
            c: ContactWire = {
                "id": cid,
                "phase": _PHASE_NAMES[int(ph)],
                "touch_m": [tx, ty],
                "pointer_m": [px, py],
                "touch_px": [tpx, tpy],
                "pointer_px": [ppx, ppy],
                "tension": ten,
                "material": names[mi] if mi >= 0 else PASS_THROUGH,
            }
            if self.string:
                c["string"] = {"length_px": ln, "dir": [dx, dy]}
            if self.pressure:
                wire: dict[str, Any] = c  # type: ignore[assignment]
                wire["pressure"] = None if math.isnan(pr) else pr
                wire["load_gain"] = lg
            out.append(c)
        return out


class _Identity:
    """Metres as pixels: the mapping of the throw-away device `Pipeline.warm_up` steps."""

    def begin(self, contact: int, x: float, y: float) -> None:
        pass

    def end(self, contact: int) -> None:
        pass

    def to_px(self, contact: int, x: float, y: float) -> tuple[float, float]:
        return (x, y)

    def affine(self) -> tuple[float, float, float, float, float, float]:
        return (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)


WARM_UP_WAIT_S = 2.0
"""How long Pipeline.warm_up waits for the compiled tick before the clock starts."""
DENSE_IDS = 1 << 16
"""Contact ids below this are found through a table, others by binary search."""
_SERIAL = itertools.count(1)


class _Compiled:
    """The compiled tick for one set of row loops, and whether it is ready to call.

    Compiling takes seconds the first time numba sees the sources (a fraction
    of one when its cache has them). `Pipeline.warm_up` compiles on a
    background thread and waits a little; until the thread is done, ticks run
    `tick.tick` as plain Python (the same code, so the same results, slower).
    A pipeline nobody warmed up compiles at its first tick.
    """

    def __init__(self, fn: Any) -> None:
        self.fn = fn
        self.ready = threading.Event()
        self.background = False
        if fn is tick.tick:  # no numba: nothing to compile
            self.ready.set()


_TICK: dict[int, _Compiled] = {}
"""Per process, keyed by the id of the row stepper's loops."""


class Pipeline:
    """One scene, compiled, stepping every contact of a device in one call per tick.

    Per tick, one call of stiction.scene.tick.tick (numba-compiled when
    installed) groups the samples by contact, finds the material under every
    contact, advances every contact with friction on its simulator row,
    copies pass-through contacts, and writes only the fields the scene's
    effects produce. The results are those of `NaivePipeline`
    (tests/scene/test_scene_batch.py).

    Each contact's row holds its material's parameters, tagged with this
    pipeline's serial; a row holding another tag (an earlier scene, or
    parameters since changed by set_params) takes this pipeline's values at
    the next tick, so changes apply to contacts already on a material.
    A mapping without an affine form (relative mapping) runs NaivePipeline.
    """

    def __init__(
        self,
        scene: Scene,
        backend: SimBackend,
        defaults: Mapping[str, float],
        *,
        compiled: bool = True,
    ) -> None:
        self.compiled = compiled
        """False runs the tick as plain Python (tests of that path)."""
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
        self._table: npt.NDArray[np.float64] | None = None
        """Row i holds names[i]'s parameters; row len(names) + i the frictionless ones."""
        self._tick: Any = None
        self._geometry()

    def wire(self) -> SceneWire:
        return self._naive.wire()

    # ------------------------------------------------------------ set-up
    def _geometry(self) -> None:
        """The scene's regions as arrays for the compiled tick."""
        names = self.names
        regions = self.scene.regions
        gi = np.zeros((max(len(regions), 1), 4), dtype=np.int64)
        gf = np.zeros((max(len(regions), 1), 4))
        pts: list[tuple[float, float]] = []
        for k, region in enumerate(regions):
            shape = region.shape
            mat = names.index(region.material) if region.material in names else -1
            if isinstance(shape, Rect):
                gi[k, :2] = (tick.RECT, mat)
                gf[k] = (shape.x, shape.y, shape.w, shape.h)
            elif isinstance(shape, Circle):
                gi[k, :2] = (tick.CIRCLE, mat)
                gf[k, :3] = (shape.cx, shape.cy, shape.r)
            else:
                gi[k] = (tick.POLYGON, mat, len(pts), len(pts) + len(shape.points))
                gf[k] = shape.bbox
                pts.extend(shape.points)
        self._gi, self._gf = gi, gf
        self._pts = np.array(pts, dtype=np.float64).reshape(-1, 2) if pts else np.zeros((1, 2))
        outside = self.scene.outside
        self._cfg = np.array(
            [
                self.friction,
                self.string,
                self.pressure,
                len(regions),
                names.index(outside) if outside in names else -1,
                len(names),
            ],
            dtype=np.int64,
        )
        pl = self.scene.pressure_load
        self._pl = np.array([pl.min_gain, pl.max_gain, pl.exponent])

    def _ready(self) -> tuple[Any, npt.NDArray[np.float64], _Compiled]:
        if self._table is None:
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
            key = id(stepper.loops)
            if key not in _TICK:
                fn = stepper.compile(tick.tick, tick.CALLEES) if self.compiled else tick.tick
                _TICK[key] = _Compiled(fn)
            self._stepper, self._table = stepper, table
            self._tick = _TICK[key] if self.compiled else _Compiled(tick.tick)
        return self._stepper, self._table, self._tick

    def _slots(self, dev: DeviceRun) -> _Slots:
        stepper, _, _ = self._ready()
        slots: _Slots | None = dev.slots
        if slots is None:
            slots = dev.slots = _Slots(stepper)
            slots.names = self.names
        elif slots.names != self.names:
            # Another scene: its material indices become this scene's.
            names = self.names
            remap = np.array([names.index(n) if n in names else -1 for n in slots.names] + [-1])
            col = slots.L[:, tick.LMAT].astype(np.int64)
            slots.L[:, tick.LMAT] = remap[col]
            slots.names = names
        return slots

    # -------------------------------------------------------------- step
    def step(
        self, dev: DeviceRun, t: float, prev_t: float, samples: Iterable[PenSample]
    ) -> list[ContactWire]:
        """Advance every contact of one device to tick time `t` (see NaivePipeline.step)."""
        if getattr(dev.mapping, "affine", None) is None:
            return self._naive.step(dev, t, prev_t, samples)
        return self.step_arrays(dev, t, prev_t, SampleArrays.from_samples(samples)).wire()

    def step_arrays(
        self, dev: DeviceRun, t: float, prev_t: float, s: SampleArrays
    ) -> ContactArrays:
        """Advance every contact of one device to `t`; the result as arrays."""
        slots = self._slots(dev)
        table, compiled = self._table, self._tick  # set by _slots' _ready()
        ready = compiled.ready.is_set()
        if ready:
            fn = compiled.fn
        elif compiled.background:
            fn = tick.tick  # still compiling on the warm-up thread
        else:
            fn = compiled.fn  # compiles now, at this first call
        mapping: Any = dev.mapping
        aff = slots.affine(mapping.affine())
        n = -1
        out = np.empty((max(len(dev.tracks), 1), tick.OCOLS))
        for _ in range(2):
            iw, fw, bw = slots.scratch(s.contact.shape[0], slots.order_ids.shape[0])
            n = fn(
                slots.S,
                slots.L,
                slots.order_ids,
                slots.order_slots,
                slots.pos_of,
                s.contact,
                s.t,
                s.x,
                s.y,
                s.tip,
                s.in_range,
                s.pressure,
                table,
                self._gi,
                self._gf,
                self._pts,
                self._cfg,
                aff,
                self._pl,
                t,
                prev_t,
                out,
                iw,
                fw,
                bw,
            )
            if n >= 0:
                break
            if n != -1:
                raise RuntimeError(f"scene tick refused its arguments ({n})")
            self._add_contacts(dev, slots, s)
            out = np.empty((len(dev.tracks), tick.OCOLS))
        if not ready and fn is compiled.fn:
            compiled.ready.set()
        values = out[:n]
        ids = slots.order_ids
        result = ContactArrays(ids, values, self.names, self.string, self.pressure)
        if slots.iw[2, n]:  # the tick counted contacts that ended
            ended = values[:, tick.OPHASE] == tick.UP_C
            known = dev.tracks
            for cid in ids[ended].tolist():
                i = known.pop(cid)
                slots.free.append(i)
                slots.L[i, tick.LHASSIM] = 0.0
                mapping.end(cid)
            slots.reorder(known)
        return result

    def fork(self, dev: DeviceRun) -> DeviceRun | None:
        """A copy of `dev`'s contact state to step instead of it, or None.

        Stepping the copy computes `dev`'s next tick without committing it
        (the daemon's prepared tick, stiction.daemon.prepare); `adopt` then
        makes it `dev`'s state, or it is dropped. Only a device whose
        mapping has an affine form is forked: that mapping is a pure
        function (its begin and end do nothing), while a relative mapping
        keeps a cursor of its own that stepping a copy would move."""
        if getattr(dev.mapping, "affine", None) is None:
            return None
        slots: _Slots | None = dev.slots
        return DeviceRun(dev.mapping, dict(dev.tracks), None if slots is None else slots.copy())

    @staticmethod
    def adopt(dev: DeviceRun, fork: DeviceRun) -> None:
        """Make a stepped fork's state `dev`'s own (the fork is not used again)."""
        dev.tracks = fork.tracks
        dev.slots = fork.slots

    def warm_up(self, wait: float | None = None) -> bool:
        """Compile (or load from numba's cache) the batch tick before the first tick.

        The daemon calls this before it starts its clock. Compiling runs on a
        background thread; this waits up to `wait` seconds for it. By
        default that is WARM_UP_WAIT_S when numba's cache holds the tick
        (loading it takes well under that), and no wait at all when it does
        not: compiling takes seconds to a minute, and waiting 2 s of it
        would only hold up the first frame. Until the thread is done, ticks
        run the tick as plain Python, so a first compilation never holds up
        the first frame. Returns whether the compiled tick is ready.
        """
        stepper, _, compiled = self._ready()
        if compiled.ready.is_set():
            return True
        if wait is None:
            cached = getattr(stepper, "is_cached", None)
            known = cached(compiled.fn) if cached is not None else None
            wait = 0.0 if known is False else WARM_UP_WAIT_S
        if not compiled.background:
            compiled.background = True
            threading.Thread(
                target=self._compile, args=(compiled,), name="stiction-compile", daemon=True
            ).start()
        return bool(compiled.ready.wait(wait))

    def _compile(self, compiled: _Compiled) -> None:
        """Call the compiled tick once on a throw-away device: numba compiles it."""
        stepper, table, _ = self._ready()
        slots = _Slots(stepper)
        n = 1
        slots.order_ids = np.zeros(n, dtype=np.int64)
        slots.order_slots = np.zeros(n, dtype=np.int64)
        slots.pos_of[0] = 0
        f = np.zeros(n)
        b = np.ones(n, dtype=np.bool_)
        compiled.fn(
            slots.S,
            slots.L,
            slots.order_ids,
            slots.order_slots,
            slots.pos_of,
            np.zeros(n, dtype=np.int64),
            f,
            f,
            f,
            b,
            b,
            np.full(n, math.nan),
            table,
            self._gi,
            self._gf,
            self._pts,
            self._cfg,
            np.array(_Identity().affine()),
            self._pl,
            0.0,
            -math.inf,
            np.empty((n, tick.OCOLS)),
            *slots.scratch(n, n),
        )
        compiled.ready.set()

    def holds_simulator(self, dev: DeviceRun, contact: int) -> bool:
        """Whether a live contact is simulated (on friction, or gliding back from it)."""
        slots: _Slots | None = dev.slots
        if slots is None or contact not in dev.tracks:
            return False
        return bool(slots.L[dev.tracks[contact], tick.LHASSIM] != 0.0)

    def _add_contacts(self, dev: DeviceRun, slots: _Slots, s: SampleArrays) -> None:
        """Slots for the contacts first seen this tick, their first sample as their last one."""
        known = dev.tracks
        uniq, first = np.unique(s.contact, return_index=True)
        for cid, k in zip(uniq.tolist(), first.tolist(), strict=True):
            if cid in known:
                continue
            if not slots.free:
                slots.grow()
            i = slots.free.pop()
            known[cid] = i
            lr = slots.L[i]
            lr[:] = 0.0
            lr[tick.LX], lr[tick.LY], lr[tick.LT] = s.x[k], s.y[k], s.t[k]
            lr[tick.LTIP], lr[tick.LRANGE], lr[tick.LPRESS] = s.tip[k], s.in_range[k], s.pressure[k]
            lr[tick.LPHASE] = tick.UP_C
            lr[tick.LMAT] = -1
            dev.mapping.begin(cid, float(s.x[k]), float(s.y[k]))
        slots.reorder(known)

    def end_all(self, dev: DeviceRun) -> list[ContactWire]:
        """End every contact of a device that went away: each reported once as "up"."""
        slots: _Slots | None = dev.slots
        if slots is None or getattr(dev.mapping, "affine", None) is None:
            return self._naive.end_all(dev)
        out: list[ContactWire] = []
        for cid in sorted(dev.tracks):
            i = dev.tracks[cid]
            x, y = float(slots.L[i, tick.LX]), float(slots.L[i, tick.LY])
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
                p = float(slots.L[i, tick.LPRESS])
                pressure = None if math.isnan(p) else p
                wire: dict[str, Any] = c  # type: ignore[assignment]
                wire["pressure"] = pressure
                wire["load_gain"] = self.scene.pressure_load.gain(pressure)
            out.append(c)
            dev.mapping.end(cid)
            slots.free.append(i)
            slots.L[i, tick.LHASSIM] = 0.0
        dev.tracks.clear()
        slots.reorder(dev.tracks)
        return out
