"""The Huion string-descriptor initialisation, through pyusb with a backend object.

pyusb accepts a backend (`usb.core.find(backend=...)`); the one here plays a
Huion tablet's USB device: it answers GET_DESCRIPTOR(string, index) control
transfers on endpoint 0 like the hardware does and stalls (EPIPE) where the
firmware has no such string. The production code builds the transfer and
parses the answer unchanged; the backend records every request it got.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pytest
import usb.backend
import usb.core

from stiction.drivers.hid.usb_init import huion_init, parse_huion_params
from stiction.errors import DeviceError

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


def _string(payload: bytes) -> bytes:
    return bytes((2 + len(payload), 3)) + payload


@dataclass
class HuionUsbBackend(usb.backend.IBackend):  # type: ignore[misc]
    """A tablet on a USB bus, as pyusb's backend interface sees it."""

    strings: dict[int, bytes]
    present: bool = True
    requests: list[tuple[int, int, int, int, int]] = field(default_factory=list)

    def enumerate_devices(self) -> Any:
        if self.present:
            yield _DeviceDescriptor()

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


# HS610: 50800 x 31750 lines at 5080 lpi (10 x 6.25 in), 8192 pressure levels.
V2 = _string(
    (50800).to_bytes(3, "little")
    + (31750).to_bytes(3, "little")
    + (8191).to_bytes(2, "little")
    + (5080).to_bytes(2, "little")
    + bytes(6)
)
V1 = _string(
    (20000).to_bytes(2, "little")
    + (12500).to_bytes(2, "little")
    + bytes(2)
    + (2047).to_bytes(2, "little")
    + (2000).to_bytes(2, "little")
)


def test_v2_string_200_gives_the_active_area() -> None:
    backend = HuionUsbBackend({200: V2})
    params = huion_init(VID, PID, backend=backend)
    assert (params.index, params.max_x, params.max_y) == (200, 50800, 31750)
    assert (params.max_pressure, params.resolution_lpi) == (8191, 5080)
    assert params.size_m == pytest.approx((0.254, 0.15875))
    # One standard GET_DESCRIPTOR(string 200, en-US) on endpoint 0, nothing else.
    assert backend.requests == [(0x80, 6, 0x03C8, 0x0409, 255)]


def test_older_firmware_falls_back_to_string_100() -> None:
    backend = HuionUsbBackend({100: V1})
    params = huion_init(VID, PID, backend=backend)
    assert (params.index, params.max_x, params.max_y, params.resolution_lpi) == (
        100,
        20000,
        12500,
        2000,
    )
    assert params.size_m == pytest.approx((0.254, 0.15875))
    assert [r[2] for r in backend.requests] == [0x03C8, 0x0364]


def test_no_parameter_string_is_a_clear_error() -> None:
    with pytest.raises(DeviceError, match="neither string descriptor 200 nor 100"):
        huion_init(VID, PID, backend=HuionUsbBackend({}))


def test_absent_device_is_a_clear_error() -> None:
    with pytest.raises(DeviceError, match="256c:006d not found"):
        huion_init(VID, PID, backend=HuionUsbBackend({200: V2}, present=False))


@pytest.mark.parametrize(
    "raw",
    [
        _string(b"\x01\x02"),  # too short
        bytes((18, 2)) + bytes(16),  # not a string descriptor
        _string(bytes(16)),  # zero resolution and extents
    ],
)
def test_implausible_answers_are_rejected(raw: bytes) -> None:
    with pytest.raises(DeviceError):
        huion_init(VID, PID, backend=HuionUsbBackend({200: raw}))
    with pytest.raises(DeviceError):
        parse_huion_params(raw, 200)
