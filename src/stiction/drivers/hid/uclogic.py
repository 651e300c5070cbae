"""Huion / UC-Logic full-resolution mode: a report descriptor for it and the report fix-up.

After the string-descriptor initialisation (usb_init.py) these tablets send
pen reports their own firmware descriptor does not describe. The facts
below follow Linux drivers/hid/hid-uclogic-{params,core}.c (GPL-2.0; only
the report layouts are taken, the descriptors here are written from the HID
specification):

- v2 (string 200): report ID 8. Byte 1 holds tip (bit 0), barrel
  (bit 1), secondary barrel (bit 2); bit 5 marks a frame-button report,
  not a pen report. Coordinates are "fragmented": X low 16 bits at bytes
  2-3, Y low 16 at 4-5, pressure at 6-7, then the high bytes of X (8)
  and Y (9), then tilt X (10) and Y (11). The tablet reports no in-range
  bit: every pen report means the pen is in range.
- v1 (string 100): report ID 7, X at 2-3, Y at 4-5, pressure at 6-7; the
  in-range bit (bit 6 of byte 1) is inverted.

`fixup_v2` moves the bytes into the order the generated descriptor
declares (X 24 bits at 2-4, Y 24 bits at 5-7, pressure at 8-9), sets the
in-range bit and drops frame-button reports; `fixup_v1` inverts the bit.
"""

from __future__ import annotations

from collections.abc import Callable

from stiction.drivers.hid.usb_init import HuionParams

PROXIMITY_TIMEOUT_S = 0.1  # v2 has no in-range bit: gone 100 ms after the last report
PEN_V1_ID = 0x07
PEN_V2_ID = 0x08
IN_RANGE_BIT = 0x40
FRAME_FLAG = 0x20


def _item(prefix: int, value: int, size: int) -> bytes:
    code = {1: 1, 2: 2, 4: 3}[size]
    return bytes([prefix | code]) + value.to_bytes(size, "little", signed=value < 0)


def _pen_descriptor(params: HuionParams, report_id: int, coord_bits: int) -> bytes:
    # Physical extents in 10^-4 inch (the kernel uses 10^-3; finer loses less to rounding).
    phys_x = params.max_x * 10000 // params.resolution_lpi
    phys_y = params.max_y * 10000 // params.resolution_lpi
    big = max(params.max_x, params.max_y, phys_x, phys_y) >= 1 << 15
    coord_size = 4 if big else 2
    d = bytearray()
    d += b"\x05\x0d\x09\x02\xa1\x01"  # Digitizer / Pen / Collection (Application)
    d += _item(0x84, report_id, 1)  # Report ID
    d += b"\x09\x20\xa1\x00"  # Stylus, Collection (Physical)
    d += b"\x15\x00\x25\x01\x75\x01"  # Logical 0..1, Report Size 1
    d += b"\x09\x42\x09\x44\x09\x5a\x95\x03\x81\x02"  # Tip, Barrel, Secondary Barrel
    d += b"\x95\x03\x81\x03"  # 3 bits padding (bit 5: frame flag, dropped)
    d += b"\x09\x32\x95\x01\x81\x02"  # In Range
    d += b"\x95\x01\x81\x03"  # 1 bit padding
    d += b"\xa4\x05\x01\x65\x13\x55\x0c\x35\x00"  # Push; Desktop; inch; 10^-4; phys min 0
    d += _item(0x74, coord_bits, 1) + b"\x95\x01"  # Report Size, Count 1
    d += b"\x09\x30" + _item(0x24, params.max_x, coord_size) + _item(0x44, phys_x, coord_size)
    d += b"\x81\x02"
    d += b"\x09\x31" + _item(0x24, params.max_y, coord_size) + _item(0x44, phys_y, coord_size)
    d += b"\x81\x02\xb4"  # Input, Pop
    d += b"\x09\x30" + _item(0x24, params.max_pressure, 2) + b"\x75\x10\x81\x02"  # Tip Pressure
    if report_id == PEN_V2_ID:
        # X Tilt, Y Tilt: -127..127 degrees
        d += b"\x09\x3d\x09\x3e\x15\x81\x25\x7f\x75\x08\x95\x02\x81\x02"
    d += b"\xc0\xc0"
    return bytes(d)


def pen_descriptor(params: HuionParams) -> bytes:
    """The report descriptor of the pen report this tablet sends after initialisation."""
    if params.index == 200:
        return _pen_descriptor(params, PEN_V2_ID, 24)
    return _pen_descriptor(params, PEN_V1_ID, 16)


def fixup_v2(data: bytes) -> bytes | None:
    if not data or data[0] != PEN_V2_ID:
        return data
    if len(data) < 10:
        return data  # short: left for the stream to count
    if data[1] & FRAME_FLAG:
        return None  # a frame-button report in the pen report's clothes
    b = bytearray(data)
    b[1] |= IN_RANGE_BIT
    lo_p, hi_p = data[6], data[7]
    b[2], b[3], b[4] = data[2], data[3], data[8]  # X: low 16, high 8
    b[5], b[6], b[7] = data[4], data[5], data[9]  # Y: low 16, high 8
    b[8], b[9] = lo_p, hi_p
    return bytes(b)


def fixup_v1(data: bytes) -> bytes | None:
    # Bit 5 marks frame-button reports only on v1 tablets whose button pad
    # was switched on (string 123); stiction does not, so it is kept.
    if not data or data[0] != PEN_V1_ID or len(data) < 2:
        return data
    b = bytearray(data)
    b[1] ^= IN_RANGE_BIT
    return bytes(b)


FIXUPS: dict[str, Callable[[bytes], bytes | None]] = {
    "uclogic-v1": fixup_v1,
    "uclogic-v2": fixup_v2,
}
"""By the names the device table's `report_fixup` uses."""


def fixup(params: HuionParams) -> Callable[[bytes], bytes | None]:
    return fixup_v2 if params.index == 200 else fixup_v1
