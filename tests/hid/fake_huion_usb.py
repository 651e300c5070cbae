"""A pyusb backend object that plays a Huion tablet's USB device (shared by tests).

It answers GET_DESCRIPTOR(string, index) control transfers on endpoint 0
like the hardware does and stalls (EPIPE) where the firmware has no such
string, and records every request. The production code builds the transfer
and parses the answer unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import usb.backend
import usb.core

VID, PID = 0x256C, 0x006D


@dataclass
class _DeviceDescriptor:
    idVendor: int = VID
    idProduct: int = PID
    bLength: int = 18
    bDescriptorType: int = 1
    bcdUSB: int = 0x0200
    bDeviceClass: int = 0
    bDeviceSubClass: int = 0
    bDeviceProtocol: int = 0
    bMaxPacketSize0: int = 64
    bcdDevice: int = 0x0100
    iManufacturer: int = 1
    iProduct: int = 2
    iSerialNumber: int = 0
    bNumConfigurations: int = 1
    address: int = 4
    bus: int = 1
    port_number: int = 3
    port_numbers: tuple[int, ...] = (3,)
    speed: int = 2


def string_descriptor(payload: bytes) -> bytes:
    """A USB string descriptor: bLength, bDescriptorType 3, payload."""
    return bytes((2 + len(payload), 3)) + payload


@dataclass
class HuionUsbBackend(usb.backend.IBackend):  # type: ignore[misc]
    """A tablet on a USB bus, as pyusb's backend interface sees it."""

    strings: dict[int, bytes]
    present: bool = True
    vid: int = VID
    pid: int = PID
    requests: list[tuple[int, int, int, int, int]] = field(default_factory=list)

    def enumerate_devices(self) -> Any:
        if self.present:
            yield _DeviceDescriptor(idVendor=self.vid, idProduct=self.pid)

    def get_device_descriptor(self, dev: Any) -> Any:
        return dev

    def open_device(self, dev: Any) -> Any:
        return object()

    def close_device(self, handle: Any) -> None:
        pass

    def ctrl_transfer(
        self,
        handle: Any,
        bmRequestType: int,
        bRequest: int,
        wValue: int,
        wIndex: int,
        data: Any,
        timeout: int,
    ) -> int:
        self.requests.append((bmRequestType, bRequest, wValue, wIndex, len(data)))
        if bmRequestType != 0x80 or bRequest != 6 or wValue >> 8 != 3:
            raise usb.core.USBError("Pipe error", errno=32)
        answer = self.strings.get(wValue & 0xFF)
        if answer is None:
            raise usb.core.USBError("Pipe error", errno=32)
        n = min(len(answer), len(data))
        data[:n] = type(data)("B", answer[:n])
        return n


def v2_answer(max_x: int, max_y: int, max_pressure: int, lpi: int) -> bytes:
    """String 200 of a v2 tablet: le24 max X and Y, le16 pressure and resolution."""
    return string_descriptor(
        max_x.to_bytes(3, "little")
        + max_y.to_bytes(3, "little")
        + max_pressure.to_bytes(2, "little")
        + lpi.to_bytes(2, "little")
        + bytes(6)
    )


def v1_answer(max_x: int, max_y: int, max_pressure: int, lpi: int) -> bytes:
    """String 100 of a v1 tablet: le16 max X and Y, 2 unused bytes, pressure, resolution."""
    return string_descriptor(
        max_x.to_bytes(2, "little")
        + max_y.to_bytes(2, "little")
        + bytes(2)
        + max_pressure.to_bytes(2, "little")
        + lpi.to_bytes(2, "little")
    )


# HS610: 50800 x 31750 lines at 5080 lpi (10 x 6.25 in), 8192 pressure levels.
V2 = v2_answer(50800, 31750, 8191, 5080)
V1 = v1_answer(20000, 12500, 2047, 2000)
