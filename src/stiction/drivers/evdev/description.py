"""What an evdev device says about itself, independent of where that came from.

A live node (ioctls through python-evdev), an evemu description and a
`libinput record` header all reduce to the same `DeviceDescription`, so the
frame assembler and the unit conversion never care whether they are reading
hardware or a file.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from evdev import ecodes

from stiction.drivers.limits import MAX_SLOTS

EV_SYN = ecodes.EV_SYN
EV_KEY = ecodes.EV_KEY
EV_ABS = ecodes.EV_ABS

#: Multi-touch protocol B codes that hold per-slot state.
MT_CODES = frozenset(
    code
    for code in range(ecodes.ABS_MT_TOUCH_MAJOR, ecodes.ABS_MT_TOOL_Y + 1)
    if code != ecodes.ABS_MT_SLOT
)

PEN_TOOLS = (
    ecodes.BTN_TOOL_PEN,
    ecodes.BTN_TOOL_RUBBER,
    ecodes.BTN_TOOL_BRUSH,
    ecodes.BTN_TOOL_PENCIL,
    ecodes.BTN_TOOL_AIRBRUSH,
    ecodes.BTN_TOOL_MOUSE,
    ecodes.BTN_TOOL_LENS,
)
FINGER_TOOLS = (
    ecodes.BTN_TOOL_FINGER,
    ecodes.BTN_TOOL_DOUBLETAP,
    ecodes.BTN_TOOL_TRIPLETAP,
    ecodes.BTN_TOOL_QUADTAP,
    ecodes.BTN_TOOL_QUINTTAP,
)


@dataclass(frozen=True, slots=True)
class AbsAxis:
    """`struct input_absinfo`: resolution in units/mm (units/radian for tilt).

    `resolution` is a float because a configured size may not divide evenly.
    """

    value: int
    minimum: int
    maximum: int
    fuzz: int = 0
    flat: int = 0
    resolution: float = 0


@dataclass(frozen=True)
class DeviceDescription:
    """Identity and capabilities of one event node."""

    name: str
    bustype: int = 0
    vendor: int = 0
    product: int = 0
    version: int = 0
    properties: frozenset[int] = frozenset()
    keys: frozenset[int] = frozenset()
    axes: dict[int, AbsAxis] = field(default_factory=dict)
    #: other event types present (EV_MSC, EV_REL, ...): type -> codes
    other: dict[int, frozenset[int]] = field(default_factory=dict)
    #: udev properties where known (ID_INPUT_TABLET=1, ...)
    udev: dict[str, str] = field(default_factory=dict)

    @property
    def vid_pid(self) -> str:
        return f"{self.vendor:04x}:{self.product:04x}"

    @property
    def is_multitouch(self) -> bool:
        """Protocol B: slots and tracking ids (protocol A devices are read single-touch)."""
        return (
            ecodes.ABS_MT_SLOT in self.axes
            and ecodes.ABS_MT_TRACKING_ID in self.axes
            and ecodes.ABS_MT_POSITION_X in self.axes
            and ecodes.ABS_MT_POSITION_Y in self.axes
        )

    @property
    def num_slots(self) -> int:
        slot = self.axes.get(ecodes.ABS_MT_SLOT)
        if slot is None or not self.is_multitouch:
            return 0
        # The kernel allows at most MAX_SLOTS; a recording claiming 2^31 must not
        # allocate them (events for slots beyond are counted as invalid).
        return max(0, min(slot.maximum + 1, MAX_SLOTS))

    @property
    def position_codes(self) -> tuple[int, int]:
        """The axes whose values become contact positions."""
        if self.is_multitouch:
            return ecodes.ABS_MT_POSITION_X, ecodes.ABS_MT_POSITION_Y
        return ecodes.ABS_X, ecodes.ABS_Y

    @property
    def has_tool_keys(self) -> bool:
        return any(k in self.keys for k in PEN_TOOLS + FINGER_TOOLS)

    @property
    def kind(self) -> str:
        """ "pen", "touchpad", "touchscreen" or "other", as libinput would classify it.

        Capability bits decide first (they are what the kernel driver
        promises); udev's ID_INPUT_* tags break ties for devices whose bits
        are ambiguous, such as a pen without BTN_TOOL_PEN.
        """
        direct = ecodes.INPUT_PROP_DIRECT in self.properties
        has_xy = ecodes.ABS_X in self.axes and ecodes.ABS_Y in self.axes
        if self.is_multitouch:
            if self.udev.get("ID_INPUT_TOUCHSCREEN") == "1" or (
                direct and self.udev.get("ID_INPUT_TOUCHPAD") != "1"
            ):
                return "touchscreen"
            return "touchpad"
        if ecodes.BTN_TOOL_PEN in self.keys or ecodes.BTN_TOOL_RUBBER in self.keys:
            return "pen"
        if self.udev.get("ID_INPUT_TABLET") == "1" and has_xy:
            return "pen"
        if has_xy and ecodes.BTN_STYLUS in self.keys and ecodes.ABS_PRESSURE in self.axes:
            return "pen"  # UC-Logic style: stylus buttons and pressure, no tool bit
        if has_xy and ecodes.BTN_TOOL_FINGER in self.keys:
            return "touchpad"
        if has_xy and ecodes.BTN_TOUCH in self.keys:
            return "touchscreen" if direct else "touchpad"
        if self.udev.get("ID_INPUT_TOUCHPAD") == "1" and has_xy:
            return "touchpad"
        if self.udev.get("ID_INPUT_TOUCHSCREEN") == "1" and has_xy:
            return "touchscreen"
        return "other"

    def with_resolution(self, res_x: float, res_y: float) -> DeviceDescription:
        """A copy whose position axes carry the given resolution (units/mm).

        Used when the device table or the config supplies a size the kernel
        does not report; resolutions are rounded as the kernel stores ints.
        """
        axes = dict(self.axes)
        pairs = [(ecodes.ABS_X, res_x), (ecodes.ABS_Y, res_y)]
        pairs += [(ecodes.ABS_MT_POSITION_X, res_x), (ecodes.ABS_MT_POSITION_Y, res_y)]
        for code, res in pairs:
            a = axes.get(code)
            if a is not None:
                axes[code] = AbsAxis(a.value, a.minimum, a.maximum, a.fuzz, a.flat, res)
        return DeviceDescription(
            self.name,
            self.bustype,
            self.vendor,
            self.product,
            self.version,
            self.properties,
            self.keys,
            axes,
            self.other,
            self.udev,
        )
