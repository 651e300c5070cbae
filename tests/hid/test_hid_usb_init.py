"""The Huion string-descriptor initialisation, through pyusb with a backend object.

pyusb accepts a backend (`usb.core.find(backend=...)`); the one here plays a
Huion tablet's USB device: it answers GET_DESCRIPTOR(string, index) control
transfers on endpoint 0 like the hardware does and stalls (EPIPE) where the
firmware has no such string. The production code builds the transfer and
parses the answer unchanged; the backend records every request it got.
"""

from __future__ import annotations

import pytest
from fake_huion_usb import PID, V1, V2, VID, HuionUsbBackend, string_descriptor

from stiction.drivers.hid.usb_init import huion_init, parse_huion_params
from stiction.errors import DeviceError


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
        string_descriptor(b"\x01\x02"),  # too short
        bytes((18, 2)) + bytes(16),  # not a string descriptor
        string_descriptor(bytes(16)),  # zero resolution and extents
        string_descriptor("HS610 tablet....".encode("utf-16-le")),  # a model name
    ],
)
def test_implausible_answers_are_rejected(raw: bytes) -> None:
    with pytest.raises(DeviceError):
        huion_init(VID, PID, backend=HuionUsbBackend({200: raw}))
    with pytest.raises(DeviceError):
        parse_huion_params(raw, 200)
