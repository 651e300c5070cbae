"""Vendor initialisation over USB with pyusb: the Huion / UC-Logic string descriptor.

Huion (and other UC-Logic based) tablets start in a reduced "firmware" mode
whose report descriptor declares a bogus unit (in^3) and no usable size.
Reading USB string descriptor 200 (100 on older firmware) switches them to
full-resolution mode, and the string's bytes are the tablet's parameters.
Layout, after Linux drivers/hid/hid-uclogic-params.c (GPL-2.0; facts only):

- index 100 ("v1", >= 12 bytes of descriptor): max X le16 at byte 2, max Y le16
  at 4, max pressure le16 at 8, resolution (lines per inch) le16 at 10;
- index 200 ("v2", >= 18 bytes): max X le24 at 2, max Y le24 at 5, max
  pressure le16 at 8, resolution le16 at 10;
- an answer that is only UTF-16 text (some tablets return their model name
  for any unknown index) is not parameters.

Byte offsets count the descriptor header (bLength, bDescriptorType).
Both layouts were checked against the kernel source, not against a device.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from stiction.errors import DeviceError

GET_DESCRIPTOR = 0x06
STRING_DESCRIPTOR = 0x03
LANGID_EN_US = 0x0409
USB_DIR_IN_STANDARD_DEVICE = 0x80


@dataclass(frozen=True, slots=True)
class HuionParams:
    """What the tablet says about itself; `size_m` is its active area in metres."""

    index: int
    max_x: int
    max_y: int
    max_pressure: int
    resolution_lpi: int

    @property
    def size_m(self) -> tuple[float, float]:
        return (
            self.max_x / self.resolution_lpi * 0.0254,
            self.max_y / self.resolution_lpi * 0.0254,
        )


def parse_huion_params(raw: bytes, index: int) -> HuionParams:
    """Parameters from a raw string descriptor (header included); DeviceError if implausible."""
    need = 18 if index == 200 else 12
    if len(raw) < need or raw[1] != STRING_DESCRIPTOR:
        raise DeviceError(
            f"Huion string descriptor {index} is {len(raw)} bytes (need {need}) "
            "or not a string descriptor: not a compatible tablet"
        )
    if index == 200:
        max_x = int.from_bytes(raw[2:5], "little")
        max_y = int.from_bytes(raw[5:8], "little")
    else:
        max_x = int.from_bytes(raw[2:4], "little")
        max_y = int.from_bytes(raw[4:6], "little")
    if all(0x20 <= raw[i] < 0x7F and raw[i + 1] == 0 for i in range(2, need - 1, 2)):
        # Some tablets answer every unknown string index with their model name.
        raise DeviceError(f"Huion string descriptor {index} is text, not parameters")
    max_p = int.from_bytes(raw[8:10], "little")
    res = int.from_bytes(raw[10:12], "little")
    if max_x <= 0 or max_y <= 0 or res <= 0:
        raise DeviceError(
            f"Huion string descriptor {index} gives max X {max_x}, max Y {max_y}, "
            f"resolution {res}: cannot derive the tablet's size"
        )
    return HuionParams(index, max_x, max_y, max_p, res)


def _read_string_descriptor(dev: Any, index: int) -> bytes | None:
    import usb.core

    try:
        data = dev.ctrl_transfer(
            USB_DIR_IN_STANDARD_DEVICE,
            GET_DESCRIPTOR,
            (STRING_DESCRIPTOR << 8) | index,
            LANGID_EN_US,
            255,
            1000,
        )
    except usb.core.USBError as exc:
        if getattr(exc, "errno", None) == 32 or "pipe" in str(exc).lower():
            return None  # stalled: this firmware has no such string
        raise DeviceError(f"reading USB string descriptor {index} failed: {exc}") from None
    return bytes(data)


def _find(vid: int, pid: int, backend: Any, why: str) -> Any:
    import usb.core

    try:
        dev = usb.core.find(idVendor=vid, idProduct=pid, backend=backend)
    except usb.core.NoBackendError:
        raise DeviceError(f"pyusb found no libusb backend: install libusb-1.0 {why}") from None
    if dev is None:
        raise DeviceError(
            f"USB device {vid:04x}:{pid:04x} not found {why} "
            "(is it plugged in, and does the udev rule give you access to /dev/bus/usb?)"
        )
    return dev


def decode_string(raw: bytes) -> str:
    """The text of a string descriptor: UTF-16LE after the 2-byte header, NULs kept.

    NULs are kept because OpenTabletDriver's string patterns expect them
    (e.g. ``^HA60\\x00*$`` for firmware that pads its name).
    """
    return raw[2 : raw[0] if raw else 0].decode("utf-16-le", errors="replace")


def read_strings(vid: int, pid: int, indices: Iterable[int], backend: Any = None) -> dict[int, str]:
    """USB string descriptors by index (those the device has), for the catalogue's matches."""
    dev = _find(vid, pid, backend, "to read the tablet's USB strings")
    out = {}
    for index in indices:
        raw = _read_string_descriptor(dev, index)
        if raw is not None and len(raw) >= 2:
            out[index] = decode_string(raw)
    return out


def huion_init(vid: int, pid: int, backend: Any = None) -> HuionParams:
    """Find the tablet with pyusb, read string 200 (else 100), return its parameters.

    `backend` is a pyusb backend object (``usb.backend.IBackend``); None uses
    libusb. The tablet stays bound to its kernel driver: a control transfer
    on endpoint 0 needs no interface claim.
    """
    dev = _find(vid, pid, backend, "for the Huion initialisation")
    problems = []
    for index in (200, 100):
        raw = _read_string_descriptor(dev, index)
        if raw is None:
            problems.append(f"no string {index}")
            continue
        try:
            return parse_huion_params(raw, index)
        except DeviceError as exc:
            problems.append(str(exc))
    raise DeviceError(
        f"{vid:04x}:{pid:04x} answers neither string descriptor 200 nor 100 with "
        f"parameters ({'; '.join(problems)}): not a Huion/UC-Logic tablet that can be initialised"
    )
