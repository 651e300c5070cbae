"""Event stream -> frames: the kernel's SYN_REPORT-delimited snapshots of contacts.

The kernel sends state changes; a frame is the complete state at one
SYN_REPORT. Events go straight into the state, but the first change of each
axis, slot and of the key set within a frame is remembered, so a frame cut
short by SYN_DROPPED is undone whole and the last good state is kept (the
kernel's rule for SYN_DROPPED: ignore everything up to and including the next
SYN_REPORT, then re-query). The first version buffered a frame's events and
applied them at SYN_REPORT; it is kept in the tests as the oracle this one
must agree with, because one pass is half the work.

A contact is a multi-touch slot with a tracking id (protocol B) or, on a
device without slots, the tool in range. When a contact disappears, the frame
lists it in `ended` with its last published state, so consumers learn that it
ended even though the kernel only said "tracking id -1" or "tool up" and may
already have reset the axes (Wacom zeroes X/Y on proximity-out).

Impossible input is counted in `stats`, never raised: slot numbers beyond the
device's slot count, a tracking id already held by another slot, a new
tracking id without -1 first (the old contact ends), keys with
values other than 0/1/2, axis values outside the advertised range (kept as
sent: real firmware exceeds its range, e.g. the Synaptics recording), events
of types and codes the device does not have.
"""

from __future__ import annotations

import functools
import struct
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import NamedTuple

from evdev import ecodes

from stiction.drivers.evdev.description import (
    EV_ABS,
    EV_KEY,
    EV_SYN,
    FINGER_TOOLS,
    DeviceDescription,
)
from stiction.drivers.sample import Tool

#: struct input_event, as a read() of the node returns it: struct timeval (two
#: native longs, as the kernel's __kernel_ulong_t on every Linux ABI but x32),
#: u16 type, u16 code, s32 value. Here, below both its readers (device.py and
#: the generated live readers of live_code.py), so neither imports the other.
INPUT_EVENT = struct.Struct("@llHHi")

SYN_REPORT = ecodes.SYN_REPORT
SYN_DROPPED = ecodes.SYN_DROPPED
ABS_MT_SLOT = ecodes.ABS_MT_SLOT
ABS_MT_TRACKING_ID = ecodes.ABS_MT_TRACKING_ID
ABS_MT_POSITION_X = ecodes.ABS_MT_POSITION_X
ABS_MT_POSITION_Y = ecodes.ABS_MT_POSITION_Y
ABS_MT_PRESSURE = ecodes.ABS_MT_PRESSURE
ABS_MT_DISTANCE = ecodes.ABS_MT_DISTANCE
ABS_MT_TOOL_TYPE = ecodes.ABS_MT_TOOL_TYPE
MT_TOOL_PEN = 1
_PEN = Tool.PEN  # a module global reads faster than the enum's class attribute
_FINGER = Tool.FINGER
_SEQUENCES = (list, tuple)  # made once: `list | tuple` builds a union at every call
_tnew = tuple.__new__  # NamedTuple's own __new__ is a Python function: 5x slower
MT_TOOL_PALM = 2  # kernel: a palm is not a touch; a finger turning palm has lifted
ABS_X = ecodes.ABS_X
ABS_Y = ecodes.ABS_Y
ABS_PRESSURE = ecodes.ABS_PRESSURE
ABS_TILT_X = ecodes.ABS_TILT_X
ABS_TILT_Y = ecodes.ABS_TILT_Y
BTN_TOUCH = ecodes.BTN_TOUCH

#: which tool wins when several BTN_TOOL_* are down (a Wacom tool swap reports
#: the new tool before releasing the old one inside one frame).
_TOOL_ORDER: tuple[tuple[int, Tool], ...] = (
    (ecodes.BTN_TOOL_RUBBER, Tool.ERASER),
    (ecodes.BTN_TOOL_PEN, Tool.PEN),
    (ecodes.BTN_TOOL_BRUSH, Tool.PEN),
    (ecodes.BTN_TOOL_PENCIL, Tool.PEN),
    (ecodes.BTN_TOOL_AIRBRUSH, Tool.PEN),
    (ecodes.BTN_TOOL_MOUSE, Tool.UNKNOWN),
    (ecodes.BTN_TOOL_LENS, Tool.UNKNOWN),
    *((code, Tool.FINGER) for code in FINGER_TOOLS),
)

#: buttons bitmask: bit 0 = first barrel button / left, 1 = second / right, 2 = third / middle
BUTTON_BITS: dict[int, int] = {
    ecodes.BTN_STYLUS: 1,
    ecodes.BTN_LEFT: 1,
    ecodes.BTN_STYLUS2: 2,
    ecodes.BTN_RIGHT: 2,
    ecodes.BTN_STYLUS3: 4,
    ecodes.BTN_MIDDLE: 4,
}


class Contact(NamedTuple):
    """One contact in device units, as the frame left it.

    NamedTuples, not frozen dataclasses: a frame builds them on the hot path,
    and a frozen dataclass pays an object.__setattr__ per field.
    """

    id: int  # tracking id (multi-touch) or 0 (the single tool)
    slot: int | None
    tracking_id: int | None
    tool: Tool
    x: int
    y: int
    pressure: int | None
    tip: bool
    in_range: bool = True
    tilt_x: int | None = None
    tilt_y: int | None = None
    buttons: int = 0


class Frame(NamedTuple):
    """The device state at one SYN_REPORT."""

    sec: int
    usec: int
    contacts: tuple[Contact, ...]
    ended: tuple[Contact, ...] = ()

    @property
    def time(self) -> float:
        return self.sec + self.usec / 1_000_000


@dataclass
class DeviceState:
    """A snapshot queried from a live device after SYN_DROPPED.

    `slots` maps an ABS_MT_* code to one value per slot (EVIOCGMTSLOTS);
    codes missing from it keep their last known values.
    """

    keys: frozenset[int]
    axes: dict[int, int]
    slots: dict[int, list[int]] = field(default_factory=dict)


class _Slot:
    __slots__ = ("distance", "pressure", "tid", "tool_type", "x", "y")

    def __init__(self) -> None:
        self.tid = -1
        self.x = 0
        self.y = 0
        self.pressure: int | None = None
        self.distance = 0
        self.tool_type = 0

    def state(self) -> tuple[int, int, int, int | None, int, int]:
        return (self.tid, self.x, self.y, self.pressure, self.distance, self.tool_type)

    def restore(self, st: tuple[int, int, int, int | None, int, int]) -> None:
        self.tid, self.x, self.y, self.pressure, self.distance, self.tool_type = st


class FrameAssembler:
    """Feeds on (sec, usec, type, code, value) and returns a Frame at each SYN_REPORT."""

    def __init__(self, desc: DeviceDescription) -> None:
        self.desc = desc
        self._counts: Counter[str] = Counter()  # anomalies; frames are counted apart
        self._frames = 0
        self.multitouch = desc.is_multitouch
        self.num_slots = desc.num_slots
        self._n_pending = 0  # events of the frame in progress
        self._undo_abs: dict[int, int] = {}  # axis -> value at the last SYN_REPORT
        self._undo_slots: dict[int, tuple[int, int, int, int | None, int, int]] = {}
        self._keys_ok: frozenset[int] | None = None  # key set at the last SYN_REPORT
        self._dropping = False
        #: True after SYN_DROPPED until resync() (live devices) or the next frame
        self.needs_resync = False
        #: a live device's state query; when set, the SYN_REPORT that ends a dropped
        #: stretch yields the re-read state as a frame (recordings have none)
        self.query_state: Callable[[], DeviceState] | None = None
        self._keys: set[int] = set()
        self._abs: dict[int, int] = {code: a.value for code, a in desc.axes.items()}
        self._ranges = {code: (a.minimum, a.maximum) for code, a in desc.axes.items()}
        self._valid_keys = desc.keys
        self._slots = [_Slot() for _ in range(self.num_slots)]
        #: _feed_mt's stand-in while the slot number is out of range (never written)
        self._spare_slot = _Slot()
        slot_axis = desc.axes.get(ABS_MT_SLOT)
        self._slot = slot_axis.value if slot_axis is not None else 0
        self._slot_ok = 0 <= self._slot < self.num_slots
        self._has_touch_key = ecodes.BTN_TOUCH in desc.keys
        self._has_tool_keys = desc.has_tool_keys
        self._has_mt_pressure = ABS_MT_PRESSURE in desc.axes
        self._has_pressure = ecodes.ABS_PRESSURE in desc.axes
        self._has_tilt = ecodes.ABS_TILT_X in desc.axes and ecodes.ABS_TILT_Y in desc.axes
        self._pressure_min = desc.axes[ecodes.ABS_PRESSURE].minimum if self._has_pressure else 0
        self._seen_position = False
        self._last: tuple[Contact, ...] = ()  # the contacts of the last frame
        self._tid_changed = False  # a tracking id changed since the last frame
        self._dirty: set[int] = set()  # slots changed since the last frame
        self._dirty_all = True  # keys changed / single-touch state changed / resync
        self._button_state = 0
        self._keys_changed = False
        self._key_tool: Tool | None = None  # the tool the key set names (_current_single)
        self._key_touch = False  # BTN_TOUCH is down
        self._default_tool = Tool.PEN if desc.kind == "pen" else Tool.FINGER
        self._slot_start = (self._slot, self._slot_ok)
        self._seen_start = False
        self._feed_single: Callable[[Iterable[tuple[int, int, int, int, int]]], list[Frame]] | None
        self._feed_single = None
        #: batches shorter than this (events) take feed_many_general on a single-tool
        #: device: three frames of a pen, where the generated loop starts to pay
        self.short_batch = 16
        self.bind_feed()

    def bind_feed(self) -> None:
        """feed_many without its own call layer (a live read is a frame or two, where
        one more Python call per batch shows): the loop it would pick, bound to this
        instance (also by device.new_assembler, on a copy)."""
        if self.multitouch:
            self.feed_many = self._feed_mt  # type: ignore[method-assign]
        else:
            self.feed_many = functools.partial(self.feed_many_general, fast=True)  # type: ignore[method-assign]

    @property
    def stats(self) -> Counter[str]:
        """Frames made and everything counted instead of raised (see the module doc)."""
        out = Counter(self._counts)
        out["frames"] = self._frames
        return out

    # -- input ---------------------------------------------------------------

    def feed(self, sec: int, usec: int, ev_type: int, code: int, value: int) -> Frame | None:
        """Consume one event; a SYN_REPORT that completes a good frame returns it."""
        frames = self.feed_many(((sec, usec, ev_type, code, value),))
        return frames[0] if frames else None

    def feed_all(self, events: Iterable[tuple[int, int, int, int, int]]) -> list[Frame]:
        return self.feed_many(events)

    def feed_many(self, events: Iterable[tuple[int, int, int, int, int]]) -> list[Frame]:
        """Consume a batch (a read() worth, or a whole recording); the frames it completes.

        A device without slots (most pen tablets) takes `_feed_single`, a loop
        written for the device (single_code.py, made at the first batch) --
        unless the batch is shorter than `short_batch` events: that loop
        moves its state into locals and back at every call (about 0.7 us),
        more than it saves on a frame or two, the usual read() of a live
        device. Multi-touch devices take `_feed_mt`. All give the same frames
        and counters (tests/evdev/test_evdev_fast_paths.py). __init__ binds
        the choice to the instance's `feed_many`; this method makes the same
        choice for a call through the class.
        """
        if self.multitouch:
            return self._feed_mt(events)
        return self.feed_many_general(events, True)

    def _compile_single(self) -> Callable[[Iterable[tuple[int, int, int, int, int]]], list[Frame]]:
        if self._feed_single is None:
            from stiction.drivers.evdev.single_code import compile_feed

            names = {"Frame": Frame, "Contact": Contact, "ended": _ended}
            self._feed_single = compile_feed(self, names)
        return self._feed_single

    def _feed_mt(self, events: Iterable[tuple[int, int, int, int, int]]) -> list[Frame]:
        """feed_many for a multi-touch device: axes, EV_MSC and SYN_REPORT inline.

        feed_many_general's multi-touch branch with the current slot, its
        validity and the "slot already saved for undo" flag in locals; keys,
        SYN_DROPPED and the dropped stretch go one event at a time through
        feed_many_general, with the locals handed over around the call.
        """
        out: list[Frame] = []
        stats = self._counts
        ranges = self._ranges
        slots = self._slots
        dirty = self._dirty
        undo_slots = self._undo_slots
        undo_abs = self._undo_abs
        num_slots = self.num_slots
        n = self._n_pending
        cur = self._slot
        slot_ok = self._slot_ok
        spare = self._spare_slot
        slot = slots[cur] if slot_ok else spare
        saved = False  # slot `cur` is in `dirty` (its undo state is kept)
        dropping = self._dropping
        last = self._last
        made = 0  # frames made inline (_commit counts its own)
        clear_resync = False  # a frame was made: needs_resync is False from here
        has_p = self._has_mt_pressure
        tnew = _tnew
        for ev in events:
            ev_type = ev[2]
            if dropping:
                pass  # through the general path below
            elif ev_type == 3:  # EV_ABS
                n += 1
                code = ev[3]
                if code < ABS_MT_SLOT:
                    # the legacy single-touch axes of a multi-touch device: ignored
                    if code not in ranges:
                        stats["unknown_code"] += 1
                    continue
                if code == ABS_MT_SLOT:
                    cur = ev[4]
                    slot_ok = 0 <= cur < num_slots
                    if slot_ok:
                        slot = slots[cur]
                        saved = cur in dirty
                    else:
                        stats["slot_out_of_range"] += 1
                    continue
                if not slot_ok:
                    stats["slot_out_of_range"] += 1
                    continue
                try:
                    lo, hi = ranges[code]
                except KeyError:
                    stats["unknown_code"] += 1
                    continue
                if not saved:
                    saved = True
                    if cur not in dirty:
                        dirty.add(cur)
                        # slot.state(), inline
                        undo_slots[cur] = (
                            slot.tid,
                            slot.x,
                            slot.y,
                            slot.pressure,
                            slot.distance,
                            slot.tool_type,
                        )
                value = ev[4]
                if code == ABS_MT_POSITION_X:
                    slot.x = value
                elif code == ABS_MT_POSITION_Y:
                    slot.y = value
                elif code == ABS_MT_PRESSURE:
                    slot.pressure = value
                else:
                    self._set_slot_value(slot, code, value)
                    continue
                if value < lo or value > hi:
                    stats["value_out_of_range"] += 1
                continue
            elif ev_type == 0:  # EV_SYN
                if ev[3] == 0:  # SYN_REPORT
                    if self._tid_changed or self._dirty_all or self._keys_changed:
                        # contacts may begin or end, or all change: _commit() does it
                        self._slot = cur
                        self._slot_ok = slot_ok
                        self._last = last
                        out.append(self._commit(ev[0], ev[1]))  # clears `dirty`
                        last = self._last
                        clear_resync = False
                    else:
                        # the common frame, _commit()'s last branch inline: the
                        # same contacts, those of moved slots rebuilt
                        made += 1
                        clear_resync = True
                        if dirty:
                            last = _moved(last, dirty, slots, has_p, self._button_state)
                            dirty.clear()
                        out.append(tnew(Frame, (ev[0], ev[1], last, ())))
                    saved = False
                    n = 0
                    if undo_abs:
                        undo_abs.clear()
                    if undo_slots:
                        undo_slots.clear()
                    self._keys_ok = None
                    self._slot_start = (cur, slot_ok)
                    self._seen_start = self._seen_position
                    continue
            elif ev_type != 1:  # EV_KEY goes the general way
                n += 1  # EV_MSC (serials, scan codes) and others carry no contact state
                continue
            self._n_pending = n
            self._slot = cur
            self._slot_ok = slot_ok
            self._last = last
            if clear_resync:
                self.needs_resync = False
                clear_resync = False
            out.extend(self.feed_many_general((ev,)))
            last = self._last
            n = self._n_pending
            cur = self._slot
            slot_ok = self._slot_ok
            slot = slots[cur] if slot_ok else spare
            saved = False
            dropping = self._dropping
        self._n_pending = n
        self._slot = cur
        self._slot_ok = slot_ok
        self._last = last
        if clear_resync:
            self.needs_resync = False
        self._frames += made
        return out

    def feed_many_general(
        self, events: Iterable[tuple[int, int, int, int, int]], fast: bool = False
    ) -> list[Frame]:
        """feed_many for every device: the reference the fast loop is tested against.

        One pass: each event goes straight into the state, and the first change
        of each axis, slot and the key set within a frame is remembered, so
        that SYN_DROPPED can put back the last complete frame's state (the
        kernel's rule: a partial frame must not be used). This is the path of
        the live reader and of replay; it is written for speed, and a test
        checks it against a plain buffer-then-apply implementation.
        """
        if (
            fast
            and not self.multitouch
            and isinstance(events, _SEQUENCES)
            and len(events) >= self.short_batch
        ):
            return self._compile_single()(events)
        out: list[Frame] = []
        stats = self._counts
        ranges = self._ranges
        abs_ = self._abs
        keys = self._keys
        valid_keys = self._valid_keys
        mt = self.multitouch
        slots = self._slots
        dirty = self._dirty
        undo_abs = self._undo_abs
        undo_slots = self._undo_slots
        n = self._n_pending
        for sec, usec, ev_type, code, value in events:
            if self._dropping:
                if ev_type != EV_SYN:
                    stats["events_discarded"] += 1
                elif code == SYN_REPORT:
                    self._dropping = False
                    if self.query_state is not None:
                        out.append(self.resync(self.query_state(), sec, usec))
                elif code == SYN_DROPPED:
                    stats["syn_dropped"] += 1
                continue
            if ev_type == EV_ABS:
                n += 1
                if mt and code >= ABS_MT_SLOT:
                    if code == ABS_MT_SLOT:
                        self._slot = value
                        self._slot_ok = 0 <= value < self.num_slots
                        if not self._slot_ok:
                            stats["slot_out_of_range"] += 1
                        continue
                    if not self._slot_ok:
                        stats["slot_out_of_range"] += 1
                        continue
                    rng = ranges.get(code)
                    if rng is None:
                        stats["unknown_code"] += 1
                        continue
                    cur = self._slot
                    slot = slots[cur]
                    if cur not in dirty:
                        dirty.add(cur)
                        undo_slots[cur] = slot.state()
                    if code == ABS_MT_POSITION_X:
                        slot.x = value
                    elif code == ABS_MT_POSITION_Y:
                        slot.y = value
                    elif code == ABS_MT_PRESSURE:
                        slot.pressure = value
                    else:
                        self._set_slot_value(slot, code, value)
                        continue
                    if not rng[0] <= value <= rng[1]:
                        stats["value_out_of_range"] += 1
                    continue
                rng = ranges.get(code)
                if rng is None:
                    stats["unknown_code"] += 1
                    continue
                if mt:
                    continue  # the legacy single-touch axes of a multi-touch device
                if code not in undo_abs:
                    undo_abs[code] = abs_[code]
                abs_[code] = value
                if not rng[0] <= value <= rng[1]:
                    stats["value_out_of_range"] += 1
                if code <= ABS_Y:
                    self._seen_position = True
            elif ev_type == EV_KEY:
                n += 1
                if code not in valid_keys:
                    stats["unknown_code"] += 1
                    continue
                if value == 0:
                    if self._keys_ok is None:
                        self._keys_ok = frozenset(keys)
                    keys.discard(code)
                elif value == 1 or value == 2:
                    if self._keys_ok is None:
                        self._keys_ok = frozenset(keys)
                    keys.add(code)
                else:
                    stats["bad_key_value"] += 1
                    continue
                self._keys_changed = True
            elif ev_type == EV_SYN:
                if code == SYN_REPORT:
                    if n and not mt:
                        self._dirty_all = True
                    if self._keys_ok is not None and not mt:
                        self._dirty_all = True  # tool, tip and buttons follow the keys
                    out.append(self._commit(sec, usec))
                    n = 0
                    # self._end_frame(), inline: this runs at every frame
                    if undo_abs:
                        undo_abs.clear()
                    if undo_slots:
                        undo_slots.clear()
                    self._keys_ok = None
                    self._slot_start = (self._slot, self._slot_ok)
                    self._seen_start = self._seen_position
                elif code == SYN_DROPPED:
                    stats["syn_dropped"] += 1
                    stats["events_discarded"] += n
                    n = 0
                    self._rollback()
                    self._dropping = True
                    self.needs_resync = True
                # SYN_CONFIG, SYN_MT_REPORT (protocol A devices are read single-touch)
            else:
                n += 1  # EV_MSC (serials, scan codes) and others carry no contact state
        self._n_pending = n
        return out

    def _end_frame(self) -> None:
        """The frame is committed: forget how to undo it (feed_many has its own copy)."""
        if self._undo_abs:
            self._undo_abs.clear()
        if self._undo_slots:
            self._undo_slots.clear()
        self._keys_ok = None
        self._slot_start = (self._slot, self._slot_ok)
        self._seen_start = self._seen_position

    def _rollback(self) -> None:
        """Back to the state of the last complete frame (SYN_DROPPED mid-frame)."""
        abs_ = self._abs
        for code, v in self._undo_abs.items():
            abs_[code] = v
        for i, st in self._undo_slots.items():
            self._slots[i].restore(st)
            self._tid_changed = True
        if self._keys_ok is not None:
            self._keys.clear()
            self._keys.update(self._keys_ok)
            self._keys_changed = True
        self._slot, self._slot_ok = self._slot_start
        self._seen_position = self._seen_start
        self._dirty.clear()
        self._undo_abs.clear()
        self._undo_slots.clear()
        self._keys_ok = None

    def resync(self, state: DeviceState, sec: int, usec: int) -> Frame:
        """Adopt the state queried after SYN_DROPPED and report it as a frame."""
        self._dropping = False
        self._rollback()  # nothing half-applied may survive into the re-read state
        self.needs_resync = False
        self._keys.clear()  # in place: feed_many() holds a reference
        self._keys.update(k for k in state.keys if k in self._valid_keys)
        self._keys_changed = True
        for code, value in state.axes.items():
            if code in self._abs and code < ABS_MT_SLOT:
                self._abs[code] = value
        slot_value = state.axes.get(ABS_MT_SLOT)
        if slot_value is not None:
            self._slot = slot_value
            self._slot_ok = 0 <= slot_value < self.num_slots
        for code, values in state.slots.items():
            for i, value in enumerate(values[: self.num_slots]):
                self._set_slot_value(self._slots[i], code, value, resync=True)
        if self._slot_ok:
            # Without EVIOCGMTSLOTS, EVIOCGABS still gives the current slot's values.
            current = self._slots[self._slot]
            for code, value in state.axes.items():
                if code > ABS_MT_SLOT and code not in state.slots:
                    self._set_slot_value(current, code, value, resync=True)
        self._dedupe_tracking_ids()
        self._dirty_all = True
        self._counts["resyncs"] += 1
        frame = self._commit(sec, usec)
        self._end_frame()
        return frame

    def finish(self, sec: int, usec: int) -> Frame | None:
        """End every contact (stream over or device gone); None if none was active."""
        self._rollback()
        self._n_pending = 0
        if not self._last:
            return None
        ended = tuple(_ended(c) for c in self._last)
        self._last = ()
        self._tid_changed = True
        self._keys.clear()
        self._keys_changed = True
        for s in self._slots:
            s.tid = -1
        self._seen_position = False
        self._dirty_all = True
        self._end_frame()
        return _tnew(Frame, (sec, usec, (), ended))

    # -- state ---------------------------------------------------------------

    def _set_slot_value(self, slot: _Slot, code: int, value: int, resync: bool = False) -> None:
        if code == ABS_MT_TRACKING_ID:
            self._tid_changed = True
            if value < 0:
                slot.tid = -1
                return
            if value != slot.tid and not resync:
                if any(s.tid == value for s in self._slots if s is not slot):
                    # The kernel never gives one id to two slots; keep the first owner.
                    self._counts["tracking_id_reused"] += 1
                    slot.tid = -1
                    return
                if slot.tid >= 0:
                    # New id without a -1 first: the old contact ended in this frame.
                    self._counts["tracking_id_replaced"] += 1
            slot.tid = value
            return
        rng = self._ranges.get(code)
        if rng is not None and (value < rng[0] or value > rng[1]):
            self._counts["value_out_of_range"] += 1
        if code == ABS_MT_POSITION_X:
            slot.x = value
        elif code == ABS_MT_POSITION_Y:
            slot.y = value
        elif code == ABS_MT_PRESSURE:
            slot.pressure = value
        elif code == ABS_MT_DISTANCE:
            slot.distance = value
        elif code == ABS_MT_TOOL_TYPE:
            if value != slot.tool_type:
                self._tid_changed = True  # finger <-> palm changes who is a contact
            slot.tool_type = value

    def _dedupe_tracking_ids(self) -> None:
        seen: set[int] = set()
        for s in self._slots:
            if s.tid >= 0:
                if s.tid in seen:
                    self._counts["tracking_id_reused"] += 1
                    s.tid = -1
                seen.add(s.tid)

    def _buttons(self) -> int:
        keys = self._keys
        if not keys:
            return 0
        b = 0
        for code, bit in BUTTON_BITS.items():
            if code in keys:
                b |= bit
        return b

    def _current_mt(self) -> dict[int, Contact]:
        """Active slots; contacts of slots untouched since the last frame are reused."""
        out: dict[int, Contact] = {}
        prev = {c.id: c for c in self._last}
        dirty = self._dirty
        all_dirty = self._dirty_all
        buttons = self._button_state
        has_p = self._has_mt_pressure
        for i, s in enumerate(self._slots):
            tid = s.tid
            if tid < 0 or s.tool_type == MT_TOOL_PALM:
                continue
            if not all_dirty and i not in dirty:
                c = prev.get(tid)
                if c is not None and c.slot == i:
                    out[tid] = c
                    continue
            out[tid] = _tnew(
                Contact,
                (
                    tid,
                    i,
                    tid,
                    Tool.PEN if s.tool_type == MT_TOOL_PEN else Tool.FINGER,
                    s.x,
                    s.y,
                    s.pressure if has_p else None,
                    s.distance == 0,
                    True,
                    None,
                    None,
                    buttons,
                ),
            )
        return out

    def _key_state(self) -> None:
        """What follows from the keys alone, worked out when they change
        rather than at every frame (most frames only move the pen)."""
        keys = self._keys
        self._button_state = self._buttons()
        self._keys_changed = False
        self._key_tool = None
        if keys:
            for code, t in _TOOL_ORDER:
                if code in keys:
                    self._key_tool = t
                    break
        self._key_touch = BTN_TOUCH in keys

    def _current_single(self) -> Contact | None:
        if self._keys_changed:
            self._key_state()
        tool: Tool | None = None
        if self._has_tool_keys:
            tool = self._key_tool
        elif self._seen_position:
            tool = self._default_tool  # no BTN_TOOL_*: in range once it reports a position
        if tool is None:
            return None
        a = self._abs
        pressure = a.get(ABS_PRESSURE) if self._has_pressure else None
        if self._has_touch_key:
            tip = self._key_touch
        else:
            tip = pressure is not None and pressure > self._pressure_min
        tilt_x, tilt_y = (a[ABS_TILT_X], a[ABS_TILT_Y]) if self._has_tilt else (None, None)
        return _tnew(
            Contact,
            (
                0,
                None,
                None,
                tool,
                a.get(ABS_X, 0),
                a.get(ABS_Y, 0),
                pressure,
                tip,
                True,
                tilt_x,
                tilt_y,
                self._button_state,
            ),
        )

    def _contact_mt(self, i: int) -> Contact:
        s = self._slots[i]
        return _tnew(
            Contact,
            (
                s.tid,
                i,
                s.tid,
                Tool.PEN if s.tool_type == MT_TOOL_PEN else Tool.FINGER,
                s.x,
                s.y,
                s.pressure if self._has_mt_pressure else None,
                s.distance == 0,
                True,
                None,
                None,
                self._button_state,
            ),
        )

    def _commit(self, sec: int, usec: int) -> Frame:
        self.needs_resync = False
        self._frames += 1
        last = self._last
        if not self.multitouch:
            prev = last[0] if last else None
            cur = self._current_single() if self._dirty_all else prev
            self._dirty_all = False
            if cur is None:
                self._last = ()
                return _tnew(Frame, (sec, usec, (), (_ended(prev),) if prev is not None else ()))
            if cur is not prev:
                self._last = (cur,)
            return _tnew(Frame, (sec, usec, self._last, ()))
        dirty = self._dirty
        if self._keys_changed:
            self._keys_changed = False
            buttons = self._buttons()
            if buttons != self._button_state:
                self._button_state = buttons
                self._dirty_all = True  # every contact carries the buttons
        if self._tid_changed or self._dirty_all:
            # contacts may have begun or ended: rebuild and compare ids
            current = self._current_mt()
            ended: tuple[Contact, ...] = ()
            for c in last:
                if c.id not in current:
                    ended = tuple(_ended(c) for c in last if c.id not in current)
                    break
            contacts = tuple(current.values())
            self._tid_changed = self._dirty_all = False
        else:
            # the common frame: the same contacts, some of them moved
            ended = ()
            if not dirty:
                contacts = last
            else:
                contacts = _moved(
                    last, dirty, self._slots, self._has_mt_pressure, self._button_state
                )
        dirty.clear()
        self._last = contacts
        return _tnew(Frame, (sec, usec, contacts, ended))


def _moved(
    last: tuple[Contact, ...],
    dirty: set[int],
    slots: list[_Slot],
    has_p: bool,
    buttons: int,
) -> tuple[Contact, ...]:
    """The common multi-touch frame: the same contacts, those of moved slots rebuilt.

    One call per frame, the Contact built inline: a call per moved contact
    (`_contact_mt`) was a third of the frame's cost. The one place that builds
    a moved contact, for `_commit` and `_feed_mt` alike.
    """
    made = []
    for c in last:
        i = c[1]
        if i in dirty:
            s = slots[i]
            tid = s.tid
            c = _tnew(
                Contact,
                (
                    tid,
                    i,
                    tid,
                    _PEN if s.tool_type == MT_TOOL_PEN else _FINGER,
                    s.x,
                    s.y,
                    s.pressure if has_p else None,
                    s.distance == 0,
                    True,
                    None,
                    None,
                    buttons,
                ),
            )
        made.append(c)
    return tuple(made)


def _ended(c: Contact) -> Contact:
    return c._replace(tip=False, in_range=False)
