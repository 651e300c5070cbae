"""Bad descriptors, bad reports and bad files: a clear error or a counted skip, never a crash."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from stiction.drivers.fake.tablet import UGEE_M708_V2_DESCRIPTOR
from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.recording import parse_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.errors import DescriptorError, RecordingError, StictionError

# A minimal valid pen: Digitizer/Pen app, report 1, tip + X + Y in inches.
PEN = bytes.fromhex(
    "05 0d 09 02 a1 01 85 01 09 20 a1 00 09 42 15 00 25 01 75 01 95 01 81 02"
    " 75 07 81 03 05 01 65 13 55 0e 35 00 46 e8 03 26 10 27 75 10 09 30 81 02"
    " 09 31 81 02 c0 c0"
)


def test_minimal_pen_is_valid() -> None:
    desc = parse_descriptor(PEN)
    assert desc.input_reports[1].bit_size == 8 + 8 + 32
    stream = ReportStream(desc, "pen")
    assert stream.surface_size == pytest.approx((0.254, 0.254))


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        (b"", "empty"),
        (b"\x05", "truncated"),
        (b"\x26\xff", "truncated"),
        (b"\x27\xff\xff", "truncated"),
        (b"\xfe\x05\x01\x00", "long item"),
        (b"\xc0", "unbalanced"),
        (b"\x05\x01\x09\x02\xa1\x01", "never closed"),
        (b"\x76\x01\x01", "Report Size 257"),
        (b"\x96\x01\x40", "Report Count 16385"),
        (b"\x85\x00", "Report ID 0"),
        (b"\x86\x00\x01", "Report ID 256"),
        (b"\xb4", "Pop at byte 0 without a matching Push"),
        (b"\xa4" * 17, "stack overflow"),
        (b"\xf4\x00", "reserved global"),
        (b"\xd0", "reserved main"),
        (b"\x0c", "reserved item type"),
        (b"\x05\x01" * 2049, "4096-byte"),
        (b"\xa1\x01" * 65 + b"\xc0" * 65, "nested deeper"),
        # 12288 elements of 256 bits: 393 KB, beyond the kernel's 16 KiB report
        (b"\x05\x01\xa1\x01\x76\x00\x01\x96\x00\x30\x81\x03\xc0", "beyond 16384 bytes"),
        # an unnumbered report, then a numbered one
        (b"\xa1\x01\x75\x08\x95\x01\x81\x03\x85\x02\x81\x03\xc0", "mixes"),
    ],
)
def test_bad_descriptors_raise_a_clear_descriptor_error(raw: bytes, message: str) -> None:
    with pytest.raises(DescriptorError, match=message):
        parse_descriptor(raw)


def test_descriptor_error_is_a_stiction_error() -> None:
    assert issubclass(DescriptorError, StictionError)


def test_trailing_zero_byte_is_tolerated() -> None:
    assert parse_descriptor(PEN + b"\x00").input_reports[1].bit_size == 48


def _stream() -> ReportStream:
    return ReportStream(parse_descriptor(UGEE_M708_V2_DESCRIPTOR), "ugee")


def test_bad_reports_are_counted_and_skipped() -> None:
    s = _stream()
    good = bytes.fromhex("07a0c4394151410000db")
    assert len(s.feed(0.0, good)) == 1
    assert s.feed(0.1, b"") == []
    assert s.feed(0.2, good[:5]) == []  # short
    assert s.feed(0.3, b"\x63" + good[1:]) == []  # report ID 99 is not declared
    assert s.feed(0.4, b"\x0b" + bytes(63)) == []  # vendor report: valid, carries no pen
    long = s.feed(0.5, good + b"\xff" * 100)  # extra bytes are ignored, as the kernel does
    assert len(long) == 1
    assert dict(s.stats) == {
        "reports": 6,
        "samples": 2,
        "empty_reports": 1,
        "short_reports": 1,
        "unknown_report_id": 1,
        "ignored": 1,
    }


def test_state_survives_bad_reports() -> None:
    """A bad report between two good ones changes nothing for the contact."""
    s = _stream()
    down = bytes.fromhex("07a1c4394151410010db")
    first = s.feed(0.0, down)[0]
    s.feed(0.01, b"\x07\x01")
    second = s.feed(0.02, down)[0]
    assert first.tip and second.tip
    assert (first.x, first.y) == (second.x, second.y)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("N: x\nI: 3 1 2\n", "no R: line"),
        ("R: 3 05 0d\n", "says 3 bytes but carries 2"),
        ("R: 2 05 zz\n", "not a list of hex bytes"),
        ("R: two 05 0d\n", "must start with the length"),
        ("I: 3 1\nR: 1 05\n", "bus, vendor and product"),
        ("R: 1 c0\nE: 0.0 2 01\n", "says 2 bytes but carries 1"),
        ("R: 1 c0\nE: later 1 01\n", "not a number"),
    ],
)
def test_bad_recordings_raise_recording_error(text: str, message: str) -> None:
    with pytest.raises(RecordingError, match=message):
        parse_recording(text, "t.hid")


def test_cli_prints_one_line_not_a_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "bad.hid"
    bad.write_text("N: broken\nI: 3 1 2\nR: 2 a1 01\n")
    proc = subprocess.run(
        [sys.executable, "-m", "stiction", "hid", "describe", str(bad)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0
    assert "never closed" in proc.stderr
    assert "Traceback" not in proc.stderr
