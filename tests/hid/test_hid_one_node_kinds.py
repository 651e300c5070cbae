"""One HID node, several contact kinds: how its pen and its touch screen get their sizes.

Two classes of real device, each named by the captures that show it:

- built-in touch screens whose USI-pen report repeats the finger report's
  numbers in another unit (Goodix firmware: 27c6:0e00 from hid-tools' kernel
  tests, 27c6:0e51 in the Lenovo Chromebook Duet 5);
- pen displays whose touch interface also declares the firmware pen without
  a length unit (Huion Kamvas 13 and Kamvas Pro 13, bound to hid-multitouch,
  where libinput shows only the touch screen).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.pen import build_mappings, device_kind
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.errors import DeviceError


def _layouts(
    path: Path, size_m: tuple[float, float] | None = None
) -> dict[bool, tuple[float, float]]:
    desc = parse_descriptor(load_recording(path).descriptor)
    out = {}
    for m in build_mappings(desc, path.stem, size_m).values():
        for c in m.contacts:
            out.setdefault(c.finger, (round(c.width_m * 1000, 1), round(c.height_m * 1000, 1)))
    return out


@pytest.mark.parametrize(
    ("where", "name", "panel_mm"),
    [
        ("hid", "goodix-27c6-0e00-usi-pen", (253.4, 169.0)),
        ("coverage", "lenovo-chromebook-duet-5-27c60e51-1", (293.7, 165.2)),
    ],
)
def test_usi_pen_repeating_the_touch_numbers_in_inches_takes_the_touch_size(
    hid_data: Path, coverage_data: Path, where: str, name: str, panel_mm: tuple[float, float]
) -> None:
    folder = hid_data if where == "hid" else coverage_data
    sizes = _layouts(folder / f"{name}.hid")
    assert sizes[True] == panel_mm  # the finger report, read as written
    assert sizes[False] == panel_mm  # the pen: not 2.534 in (64 mm) wide
    stream = ReportStream(parse_descriptor(load_recording(folder / f"{name}.hid").descriptor), name)
    assert stream.surface_size == pytest.approx((panel_mm[0] / 1000, panel_mm[1] / 1000), abs=1e-4)


def test_a_size_given_by_the_user_still_applies_to_every_contact(hid_data: Path) -> None:
    sizes = _layouts(hid_data / "goodix-27c6-0e00-usi-pen.hid", (0.3, 0.2))
    assert sizes == {True: (300.0, 200.0), False: (300.0, 200.0)}


def test_pen_with_its_own_length_keeps_it_beside_a_touch_screen(hid_data: Path) -> None:
    """Elan's USI pen declares its own cm numbers: nothing is borrowed."""
    sizes = _layouts(hid_data / "elan-04f3-2a49-touchscreen-usi-pen.hid")
    assert sizes == {True: (294.0, 166.0), False: (294.0, 166.0)}


@pytest.mark.parametrize(
    "name",
    ["huion-kamvas-13-256c006d-2", "huion-kamvas-pro-13-256c006d-2"],
)
def test_pen_display_touch_interface_is_a_touch_screen_when_its_pen_has_no_length(
    coverage_data: Path, name: str
) -> None:
    """As libinput drops a tablet without resolution and keeps the node's touch screen."""
    desc = parse_descriptor(load_recording(coverage_data / f"{name}.hid").descriptor)
    assert device_kind(desc) == "touchscreen"
    stream = ReportStream(desc, name)
    assert stream.kind == "touchscreen"
    assert stream.surface_size == pytest.approx((0.3093, 0.1739), abs=1e-4)
    assert all(c.finger for m in stream.mappings.values() for c in m.contacts)


def test_a_pen_without_length_alone_is_still_refused(hid_data: Path) -> None:
    """Huion HS610 in firmware mode: only a pen, in in^3; its size needs the vendor's init."""
    desc = parse_descriptor(load_recording(hid_data / "huion-hs610.hid").descriptor)
    assert device_kind(desc) == "pen"
    with pytest.raises(DeviceError, match="no physical size for X"):
        ReportStream(desc, "hs610")


def test_pen_reported_as_a_mouse_is_a_pen_when_no_digitizer_report_exists(hid_data: Path) -> None:
    """XP-Pen/UGEE firmware (Deco 03): absolute X/Y and Tip Pressure in a Mouse collection.

    Without any table entry it is now a pen that needs a size, not "no pen";
    with only a size (what a catalogue of active areas gives), it decodes.
    """
    rec = load_recording(hid_data / "xp-pen-deco-03.hid")
    desc = parse_descriptor(rec.descriptor)
    assert device_kind(desc) == "pen"
    with pytest.raises(DeviceError, match="no physical size for X"):
        ReportStream(desc, "deco 03")
    stream = ReportStream(desc, "deco 03", (0.254, 0.1427))
    samples = [s for ev in rec.events for s in stream.feed(ev.t, ev.data)]
    assert sum(s.tip for s in samples) > 1000  # pressure > 0 is the tip (no tip bit)
    assert stream.stats["samples"] == len(samples) and stream.stats["clamped_positions"] == 0


def test_mouse_mode_report_with_pressure_is_not_a_pen_beside_a_digitizer_report(
    hid_data: Path,
) -> None:
    """Huion 580 also sends a Mouse report (report 9) in its default mode: the pen is report 7."""
    desc = parse_descriptor(load_recording(hid_data / "huion-580.hid").descriptor)
    stream = ReportStream(desc, "580")
    assert set(stream.mappings) == {7}
