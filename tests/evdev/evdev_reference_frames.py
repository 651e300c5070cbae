"""Test oracle: the plain buffer-then-apply frame assembler (stiction's first version).

Kept verbatim so that the optimised one-pass FrameAssembler can be checked
against it on every recording and on random streams. Original docstring:

Event stream -> frames: the kernel's SYN_REPORT-delimited snapshots of contacts.

The kernel sends state changes; a frame is the complete state at one
SYN_REPORT. Events of a frame are buffered and applied only when its
SYN_REPORT arrives, so a frame cut short by SYN_DROPPED can be thrown away
whole and the last good state is kept (the kernel's rule for SYN_DROPPED:
ignore everything up to and including the next SYN_REPORT, then re-query).

A contact is a multi-touch slot with a tracking id (protocol B) or, on a
device without slots, the tool in range. When a contact disappears, the frame
lists it in `ended` with its last published state, so consumers learn that it
ended even though the kernel only said "tracking id -1" or "tool up" and may
already have reset the axes (Wacom zeroes X/Y on proximity-out).

Impossible input is counted in `stats`, never raised: slot numbers beyond the
device's slot count, a tracking id already held by another slot, keys with
values other than 0/1/2, axis values outside the advertised range (kept as
sent: real firmware exceeds its range, e.g. the Synaptics recording), events
of types and codes the device does not have.
"""

from __future__ import annotations

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


class FrameAssembler:
    """Feeds on (sec, usec, type, code, value) and returns a Frame at each SYN_REPORT."""

    def __init__(self, desc: DeviceDescription) -> None:
        self.desc = desc
        self.stats: Counter[str] = Counter()
        self.multitouch = desc.is_multitouch
        self.num_slots = desc.num_slots
        self._pending: list[tuple[int, int, int]] = []
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
        self._published: dict[int, Contact] = {}
        self._dirty: set[int] = set()  # slots changed since the last frame
        self._dirty_all = True  # keys changed / single-touch state changed / resync
        self._button_state = 0
        self._keys_changed = False
        self._default_tool = Tool.PEN if desc.kind == "pen" else Tool.FINGER

    # -- input ---------------------------------------------------------------

    def feed(self, sec: int, usec: int, ev_type: int, code: int, value: int) -> Frame | None:
        """Consume one event; a SYN_REPORT that completes a good frame returns it."""
        if ev_type != EV_SYN:
            if self._dropping:
                self.stats["events_discarded"] += 1
            else:
                self._pending.append((ev_type, code, value))
            return None
        return self._syn(sec, usec, code)

    def feed_many(self, events: Iterable[tuple[int, int, int, int, int]]) -> list[Frame]:
        """Consume a batch (a read() worth, or a whole recording); the frames it completes.

        The same as feed() per event, with the per-event work inlined: this is
        the path of the live reader and of replay.
        """
        out: list[Frame] = []
        append = self._pending.append
        for sec, usec, ev_type, code, value in events:
            if ev_type:  # not EV_SYN
                if self._dropping:
                    self.stats["events_discarded"] += 1
                else:
                    append((ev_type, code, value))
            else:
                f = self._syn(sec, usec, code)
                if f is not None:
                    out.append(f)
        return out

    def feed_all(self, events: Iterable[tuple[int, int, int, int, int]]) -> list[Frame]:
        return self.feed_many(events)

    def _syn(self, sec: int, usec: int, code: int) -> Frame | None:
        if code == SYN_REPORT:
            if self._dropping:
                self._dropping = False
                if self.query_state is not None:
                    return self.resync(self.query_state(), sec, usec)
                return None
            pending = self._pending
            if pending:
                self._apply(pending)
                pending.clear()
            return self._commit(sec, usec)
        if code == SYN_DROPPED:
            self.stats["syn_dropped"] += 1
            self.stats["events_discarded"] += len(self._pending)
            self._pending.clear()
            self._dropping = True
            self.needs_resync = True
            return None
        return None  # SYN_CONFIG, SYN_MT_REPORT (protocol A, read single-touch)

    def resync(self, state: DeviceState, sec: int, usec: int) -> Frame:
        """Adopt the state queried after SYN_DROPPED and report it as a frame."""
        self._dropping = False
        self._pending.clear()
        self.needs_resync = False
        self._keys = set(state.keys) & set(self._valid_keys)
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
        self.stats["resyncs"] += 1
        return self._commit(sec, usec)

    def finish(self, sec: int, usec: int) -> Frame | None:
        """End every contact (stream over or device gone); None if none was active."""
        self._pending.clear()
        if not self._published:
            return None
        ended = tuple(_ended(c) for c in self._published.values())
        self._published = {}
        self._keys.clear()
        self._keys_changed = True
        for s in self._slots:
            s.tid = -1
        self._seen_position = False
        self._dirty_all = True
        return Frame(sec, usec, (), ended)

    # -- state ---------------------------------------------------------------

    def _apply(self, events: list[tuple[int, int, int]]) -> None:
        stats = self.stats
        ranges = self._ranges
        mt = self.multitouch
        abs_ = self._abs
        keys = self._keys
        valid_keys = self._valid_keys
        if not mt:
            self._dirty_all = True
        cur = self._slot
        slot_ok = self._slot_ok
        slots = self._slots
        dirty = self._dirty
        for ev_type, code, value in events:
            if ev_type == EV_ABS:
                if mt and code >= ABS_MT_SLOT:
                    if code == ABS_MT_SLOT:
                        cur = value
                        slot_ok = 0 <= value < self.num_slots
                        if not slot_ok:
                            stats["slot_out_of_range"] += 1
                        continue
                    if not slot_ok:
                        stats["slot_out_of_range"] += 1
                        continue
                    rng = ranges.get(code)
                    if rng is None:
                        stats["unknown_code"] += 1
                        continue
                    s = slots[cur]
                    dirty.add(cur)
                    if code == ABS_MT_POSITION_X:
                        s.x = value
                    elif code == ABS_MT_POSITION_Y:
                        s.y = value
                    else:
                        self._set_slot_value(s, code, value)
                        continue
                    if not rng[0] <= value <= rng[1]:
                        stats["value_out_of_range"] += 1
                    continue
                rng = ranges.get(code)
                if rng is None:
                    stats["unknown_code"] += 1
                elif rng[0] <= value <= rng[1]:
                    abs_[code] = value
                else:
                    stats["value_out_of_range"] += 1
                    abs_[code] = value
            elif ev_type == EV_KEY:
                if code not in valid_keys:
                    stats["unknown_code"] += 1
                elif value == 0:
                    keys.discard(code)
                    self._dirty_all = self._keys_changed = True
                elif value == 1 or value == 2:
                    keys.add(code)
                    self._dirty_all = self._keys_changed = True
                else:
                    stats["bad_key_value"] += 1
            # EV_MSC (serial numbers, scan codes) and others carry no contact state
        self._slot = cur
        self._slot_ok = slot_ok
        if not self._seen_position and not mt and (ABS_X in abs_ or ABS_Y in abs_):
            self._seen_position = any(t == EV_ABS and c <= ABS_Y for t, c, _ in events)

    def _set_slot_value(self, slot: _Slot, code: int, value: int, resync: bool = False) -> None:
        if code == ABS_MT_TRACKING_ID:
            if value < 0:
                slot.tid = -1
                return
            if value != slot.tid and not resync:
                if any(s.tid == value for s in self._slots if s is not slot):
                    # The kernel never gives one id to two slots; keep the first owner.
                    self.stats["tracking_id_reused"] += 1
                    slot.tid = -1
                    return
                if slot.tid >= 0:
                    # New id without a -1 first: the old contact ended in this frame.
                    self.stats["tracking_id_replaced"] += 1
            slot.tid = value
            return
        rng = self._ranges.get(code)
        if rng is not None and (value < rng[0] or value > rng[1]):
            self.stats["value_out_of_range"] += 1
        if code == ABS_MT_POSITION_X:
            slot.x = value
        elif code == ABS_MT_POSITION_Y:
            slot.y = value
        elif code == ABS_MT_PRESSURE:
            slot.pressure = value
        elif code == ABS_MT_DISTANCE:
            slot.distance = value
        elif code == ABS_MT_TOOL_TYPE:
            slot.tool_type = value

    def _dedupe_tracking_ids(self) -> None:
        seen: set[int] = set()
        for s in self._slots:
            if s.tid >= 0:
                if s.tid in seen:
                    self.stats["tracking_id_reused"] += 1
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
        prev = self._published
        dirty = self._dirty
        all_dirty = self._dirty_all
        if self._keys_changed:
            self._button_state = self._buttons()
            self._keys_changed = False
        buttons = self._button_state
        has_p = self._has_mt_pressure
        for i, s in enumerate(self._slots):
            tid = s.tid
            if tid < 0:
                continue
            if not all_dirty and i not in dirty:
                c = prev.get(tid)
                if c is not None and c.slot == i:
                    out[tid] = c
                    continue
            out[tid] = Contact(
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
            )
        return out

    def _current_single(self) -> Contact | None:
        keys = self._keys
        if self._keys_changed:
            self._button_state = self._buttons()
            self._keys_changed = False
        tool: Tool | None = None
        if self._has_tool_keys:
            if keys:
                for code, t in _TOOL_ORDER:
                    if code in keys:
                        tool = t
                        break
        elif self._seen_position:
            tool = self._default_tool  # no BTN_TOOL_*: in range once it reports a position
        if tool is None:
            return None
        a = self._abs
        pressure = a.get(ABS_PRESSURE) if self._has_pressure else None
        if self._has_touch_key:
            tip = BTN_TOUCH in keys
        else:
            tip = pressure is not None and pressure > self._pressure_min
        if self._has_tilt:
            return Contact(
                0,
                None,
                None,
                tool,
                a[ABS_X],
                a[ABS_Y],
                pressure,
                tip,
                True,
                a[ABS_TILT_X],
                a[ABS_TILT_Y],
                self._button_state,
            )
        return Contact(
            0,
            None,
            None,
            tool,
            a[ABS_X],
            a[ABS_Y],
            pressure,
            tip,
            True,
            None,
            None,
            self._button_state,
        )

    def _commit(self, sec: int, usec: int) -> Frame:
        self.needs_resync = False
        self.stats["frames"] += 1
        published = self._published
        if not self.multitouch:
            prev = published.get(0)
            cur = self._current_single() if self._dirty_all else prev
            self._dirty_all = False
            if cur is None:
                self._published = {}
                return Frame(sec, usec, (), (_ended(prev),) if prev is not None else ())
            if cur is not prev:
                self._published = {0: cur}
            return Frame(sec, usec, (cur,), ())
        current = self._current_mt()
        self._dirty.clear()
        self._dirty_all = False
        ended: tuple[Contact, ...] = ()
        if published:
            for cid in published:
                if cid not in current:
                    ended = tuple(_ended(c) for k, c in published.items() if k not in current)
                    break
        self._published = current
        return Frame(sec, usec, tuple(current.values()), ended)


def _ended(c: Contact) -> Contact:
    return c._replace(tip=False, in_range=False)
