"""What an evdev device says about itself, independent of where that came from.

A live node (ioctls through python-evdev), an evemu description and a
`libinput record` header all reduce to the same `DeviceDescription`, so the
frame assembler and the unit conversion never care whether they are reading
hardware or a file.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

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
#: the pen tools beside BTN_TOOL_PEN that a stylus node may declare alone
_STYLUS_TOOLS = (ecodes.BTN_TOOL_BRUSH, ecodes.BTN_TOOL_PENCIL, ecodes.BTN_TOOL_AIRBRUSH)
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
    #: why a resolution the node reported was set aside (sizes.apply), for the
    #: error that then asks for a size; "" when none was
    size_note: str = ""

    @property
    def vid_pid(self) -> str:
        return f"{self.vendor:04x}:{self.product:04x}"

    @property
    def is_multitouch(self) -> bool:
        """Protocol B: slots and tracking ids (protocol A devices are read single-touch).

        A slot axis whose maximum is below 0 declares no slot at all (the kernel
        never sends one; a recording can): such a node is not read as multi-touch,
        where it would have given no contact ever.
        """
        slot = self.axes.get(ecodes.ABS_MT_SLOT)
        return (
            slot is not None
            and slot.maximum >= 0
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
    def mt_protocol_a_only(self) -> bool:
        """Touches only through multi-touch protocol A: ABS_MT_POSITION_X/Y with no
        usable slots (contacts separated by SYN_MT_REPORT) and no single-touch X/Y
        to fall back on. stiction reads protocol B and single-touch nodes only."""
        return (
            not self.is_multitouch
            and ecodes.ABS_MT_POSITION_X in self.axes
            and ecodes.ABS_MT_POSITION_Y in self.axes
            and not (ecodes.ABS_X in self.axes and ecodes.ABS_Y in self.axes)
        )

    @property
    def is_pad(self) -> bool:
        """A tablet's button pad (ExpressKeys, rings, strips), not a surface.

        udev tags it ID_INPUT_TABLET_PAD; from the bits, systemd's input_id
        builtin (udev-builtin-input_id.c, `has_pad_buttons`) takes BTN_0 with
        BTN_STYLUS and no BTN_TOOL_PEN: the kernel's wacom driver gives its pad
        nodes ABS_X/ABS_Y (0..1) and BTN_STYLUS for old programs. No pad has
        pressure, so a UC-Logic pen without tool bits is never taken for one.
        """
        if ecodes.BTN_TOOL_PEN in self.keys or ecodes.BTN_TOOL_RUBBER in self.keys:
            return False
        if self.udev.get("ID_INPUT_TABLET_PAD") == "1":
            return True
        return (
            ecodes.BTN_0 in self.keys
            and ecodes.BTN_STYLUS in self.keys
            and ecodes.ABS_PRESSURE not in self.axes
            and not self.is_multitouch
        )

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
        if self.is_pad:
            return "other"  # udev tags pads ID_INPUT_TABLET too: buttons, not a surface
        if has_xy and any(k in self.keys for k in _STYLUS_TOOLS):
            return "pen"  # a pen whose only tool is an airbrush, pencil or brush
        if self.udev.get("ID_INPUT_TABLET") == "1" and has_xy:
            return "pen"
        if has_xy and ecodes.BTN_STYLUS in self.keys and ecodes.ABS_PRESSURE in self.axes:
            return "pen"  # UC-Logic style: stylus buttons and pressure, no tool bit
        if has_xy and ecodes.BTN_TOOL_FINGER in self.keys and not direct:
            return "touchpad"  # systemd's input_id: finger tools on a direct node are a screen
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
        return replace(self, axes=axes)
