"""Event stream -> frames: the kernel's SYN_REPORT-delimited snapshots of contacts.

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
from dataclasses import dataclass, field, replace

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


@dataclass(frozen=True, slots=True)
class Contact:
    """One contact in device units, as the frame left it."""

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


@dataclass(frozen=True, slots=True)
class Frame:
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
        if code == SYN_REPORT:
            if self._dropping:
                self._dropping = False
                return None
            events = self._pending
            self._pending = []
            self._apply(events)
            return self._commit(sec, usec)
        if code == SYN_DROPPED:
            self.stats["syn_dropped"] += 1
            self.stats["events_discarded"] += len(self._pending)
            self._pending.clear()
            self._dropping = True
            self.needs_resync = True
            return None
        return None  # SYN_CONFIG, SYN_MT_REPORT (protocol A, read single-touch)

    def feed_all(self, events: list[tuple[int, int, int, int, int]]) -> list[Frame]:
        out = []
        feed = self.feed
        for s, u, t, c, v in events:
            f = feed(s, u, t, c, v)
            if f is not None:
                out.append(f)
        return out

    def resync(self, state: DeviceState, sec: int, usec: int) -> Frame:
        """Adopt the state queried after SYN_DROPPED and report it as a frame."""
        self._dropping = False
        self._pending.clear()
        self.needs_resync = False
        self._keys = set(state.keys) & set(self._valid_keys)
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
        for s in self._slots:
            s.tid = -1
        self._seen_position = False
        return Frame(sec, usec, (), ended)

    # -- state ---------------------------------------------------------------

    def _apply(self, events: list[tuple[int, int, int]]) -> None:
        stats = self.stats
        for ev_type, code, value in events:
            if ev_type == EV_ABS:
                rng = self._ranges.get(code)
                if rng is None:
                    stats["unknown_code"] += 1
                    continue
                if code >= ABS_MT_SLOT and self.multitouch:
                    if code == ABS_MT_SLOT:
                        self._slot = value
                        self._slot_ok = 0 <= value < self.num_slots
                        if not self._slot_ok:
                            stats["slot_out_of_range"] += 1
                        continue
                    if not self._slot_ok:
                        stats["slot_out_of_range"] += 1
                        continue
                    self._set_slot_value(self._slots[self._slot], code, value)
                    continue
                if value < rng[0] or value > rng[1]:
                    stats["value_out_of_range"] += 1
                self._abs[code] = value
                if code <= 1:
                    self._seen_position = True
            elif ev_type == EV_KEY:
                if code not in self._valid_keys:
                    stats["unknown_code"] += 1
                elif value == 0:
                    self._keys.discard(code)
                elif value in (1, 2):
                    self._keys.add(code)
                else:
                    stats["bad_key_value"] += 1
            # EV_MSC (serial numbers, scan codes) and others carry no contact state

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

    def _current(self) -> dict[int, Contact]:
        buttons = self._buttons()
        out: dict[int, Contact] = {}
        if self.multitouch:
            has_p = self._has_mt_pressure
            for i, s in enumerate(self._slots):
                if s.tid < 0:
                    continue
                mt_tool = Tool.PEN if s.tool_type == MT_TOOL_PEN else Tool.FINGER
                out[s.tid] = Contact(
                    s.tid,
                    i,
                    s.tid,
                    mt_tool,
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
        keys = self._keys
        tool: Tool | None = None
        if self._has_tool_keys:
            for code, t in _TOOL_ORDER:
                if code in keys:
                    tool = t
                    break
        elif self._seen_position:
            tool = self._default_tool  # no BTN_TOOL_*: in range once it reports a position
        if tool is None:
            return out
        a = self._abs
        pressure = a.get(ecodes.ABS_PRESSURE) if self._has_pressure else None
        if self._has_touch_key:
            tip = ecodes.BTN_TOUCH in keys
        else:
            tip = pressure is not None and pressure > self._pressure_min
        tilt_x = a[ecodes.ABS_TILT_X] if self._has_tilt else None
        tilt_y = a[ecodes.ABS_TILT_Y] if self._has_tilt else None
        out[0] = Contact(
            0,
            None,
            None,
            tool,
            a.get(ecodes.ABS_X, 0),
            a.get(ecodes.ABS_Y, 0),
            pressure,
            tip,
            True,
            tilt_x,
            tilt_y,
            buttons,
        )
        return out

    def _commit(self, sec: int, usec: int) -> Frame:
        self.needs_resync = False
        current = self._current()
        published = self._published
        ended: tuple[Contact, ...] = ()
        if published:
            gone = [c for cid, c in published.items() if cid not in current]
            if gone:
                ended = tuple(_ended(c) for c in gone)
        self._published = current
        self.stats["frames"] += 1
        return Frame(sec, usec, tuple(current.values()), ended)


def _ended(c: Contact) -> Contact:
    return replace(c, tip=False, in_range=False)
