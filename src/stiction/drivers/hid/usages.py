"""Names of HID usages, for people reading `stiction hid describe` and `hid decode`.

Written from the HID Usage Tables (usb.org, HUT 1.4) for the pages a tablet,
touch screen or touchpad uses: Generic Desktop, Button, Consumer (the two a
pen report may carry) and Digitizers, plus the vendor range. A usage not
listed prints as its page name and hex id, so the table can stay small.
"""

from __future__ import annotations

PAGES: dict[int, str] = {
    0x01: "Generic Desktop",
    0x07: "Keyboard",
    0x08: "LEDs",
    0x09: "Button",
    0x0C: "Consumer",
    0x0D: "Digitizers",
    0x0F: "Physical Input Device",
    0x20: "Sensors",
    0x84: "Power Device",
    0x85: "Battery System",
}

GENERIC_DESKTOP: dict[int, str] = {
    0x01: "Pointer",
    0x02: "Mouse",
    0x04: "Joystick",
    0x05: "Game Pad",
    0x06: "Keyboard",
    0x07: "Keypad",
    0x08: "Multi-axis Controller",
    0x09: "Tablet PC System Controls",
    0x30: "X",
    0x31: "Y",
    0x32: "Z",
    0x33: "Rx",
    0x34: "Ry",
    0x35: "Rz",
    0x36: "Slider",
    0x37: "Dial",
    0x38: "Wheel",
    0x39: "Hat switch",
    0x3A: "Counted Buffer",
    0x3B: "Byte Count",
    0x3C: "Motion Wakeup",
    0x3D: "Start",
    0x3E: "Select",
    0x40: "Vx",
    0x41: "Vy",
    0x42: "Vz",
    0x43: "Vbrx",
    0x44: "Vbry",
    0x45: "Vbrz",
    0x46: "Vno",
    0x47: "Feature Notification",
    0x48: "Resolution Multiplier",
    0x80: "System Control",
    0x81: "System Power Down",
    0x82: "System Sleep",
    0x83: "System Wake Up",
}

DIGITIZERS: dict[int, str] = {
    0x01: "Digitizer",
    0x02: "Pen",
    0x03: "Light Pen",
    0x04: "Touch Screen",
    0x05: "Touch Pad",
    0x06: "Whiteboard",
    0x07: "Coordinate Measuring Machine",
    0x08: "3D Digitizer",
    0x09: "Stereo Plotter",
    0x0A: "Articulated Arm",
    0x0B: "Armature",
    0x0C: "Multiple Point Digitizer",
    0x0D: "Free Space Wand",
    0x0E: "Device Configuration",
    0x0F: "Capacitive Heat Map Digitizer",
    0x20: "Stylus",
    0x21: "Puck",
    0x22: "Finger",
    0x23: "Device Settings",
    0x24: "Character Gesture",
    0x30: "Tip Pressure",
    0x31: "Barrel Pressure",
    0x32: "In Range",
    0x33: "Touch",
    0x34: "Untouch",
    0x35: "Tap",
    0x36: "Quality",
    0x37: "Data Valid",
    0x38: "Transducer Index",
    0x39: "Tablet Function Keys",
    0x3A: "Program Change Keys",
    0x3B: "Battery Strength",
    0x3C: "Invert",
    0x3D: "X Tilt",
    0x3E: "Y Tilt",
    0x3F: "Azimuth",
    0x40: "Altitude",
    0x41: "Twist",
    0x42: "Tip Switch",
    0x43: "Secondary Tip Switch",
    0x44: "Barrel Switch",
    0x45: "Eraser",
    0x46: "Tablet Pick",
    0x47: "Touch Valid",
    0x48: "Width",
    0x49: "Height",
    0x51: "Contact Identifier",
    0x52: "Device Mode",
    0x53: "Device Identifier",
    0x54: "Contact Count",
    0x55: "Contact Count Maximum",
    0x56: "Scan Time",
    0x57: "Surface Switch",
    0x58: "Button Switch",
    0x59: "Pad Type",
    0x5A: "Secondary Barrel Switch",
    0x5B: "Transducer Serial Number",
    0x5C: "Preferred Color",
    0x5D: "Preferred Color is Locked",
    0x5E: "Preferred Line Width",
    0x5F: "Preferred Line Width is Locked",
    0x60: "Latency Mode",
    0x61: "Gesture Character Quality",
    0x6E: "Transducer Serial Number Part 2",
    0x6F: "No Preferred Color",
    0x70: "Preferred Line Style",
    0x71: "Preferred Line Style is Locked",
    0x90: "Transducer Software Info",
    0x91: "Transducer Vendor Id",
    0x92: "Transducer Product Id",
    0x93: "Device Supported Protocols",
    0x94: "Transducer Supported Protocols",
}

CONSUMER: dict[int, str] = {
    0x01: "Consumer Control",
    0xE2: "Mute",
    0xE9: "Volume Increment",
    0xEA: "Volume Decrement",
    0x238: "AC Pan",
}

_BY_PAGE: dict[int, dict[int, str]] = {
    0x01: GENERIC_DESKTOP,
    0x0C: CONSUMER,
    0x0D: DIGITIZERS,
    0xFF0D: DIGITIZERS,  # Wacom's vendor page mirrors the digitizer page (see devices.md)
}


def page_name(page: int) -> str:
    if page in PAGES:
        return PAGES[page]
    if page == 0xFF0D:
        return "Wacom (vendor)"
    if page >= 0xFF00:
        return f"Vendor 0x{page:04X}"
    return f"Page 0x{page:04X}"


def usage_name(usage: int) -> str:
    """``"Digitizers / Tip Switch"`` for 0x000D0042; unknown ids as hex on their page."""
    page, uid = usage >> 16, usage & 0xFFFF
    if page == 0x09:
        name = "No Button Pressed" if uid == 0 else f"Button {uid}"
    else:
        name = _BY_PAGE.get(page, {}).get(uid) or f"0x{uid:04X}"
    return f"{page_name(page)} / {name}"


def usage_hex(usage: int) -> str:
    """The key `hid decode --json` uses: the full 32-bit usage in lowercase hex."""
    return f"0x{usage:08x}"
