"""Descriptors the kernel would accept that used to exhaust stiction (issue 12).

Each is a few bytes; each crashed or exhausted `stiction devices`, `doctor`
and `hid decode` before: a 4-byte Unit Exponent (OverflowError converting
the size), thousands of variable fields (RecursionError compiling the
decoder), an array whose usage range spans 2^32 usages (MemoryError).
"""

from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.drivers.hid.decoder import ReportDecoder
from stiction.drivers.hid.descriptor import MAX_REPORT_COUNT, parse_descriptor
from stiction.drivers.hid.stream import ReportStream
from stiction.errors import DeviceError


def _h(text: str) -> bytes:
    return bytes.fromhex(text.replace(" ", ""))


# Digitizer pen with X/Y in centimetres and Unit Exponent 0x7fffffff (4-byte item).
HUGE_EXPONENT = _h(
    "050d 0902 a101 8501 0920 a100 0501 57ffffff7f 6511 3500 46ff00"
    " 0930 0931 1500 26ff00 7510 9502 8102 c0 c0"
)
# Two Input items of 12288 one-bit variable fields each.
MANY_FIELDS = _h("0509 a101 1901 2aff2f 1500 2501 7501 960030 8102 1901 2aff2f 960030 8102 c0")
# One array whose Usage Minimum/Maximum span every 32-bit usage.
HUGE_RANGE = _h("0509 a101 1b01000000 2bffffffff 1500 27ffffffff 7520 9501 8100 c0")


def test_a_huge_unit_exponent_means_no_size_not_an_overflow() -> None:
    desc = parse_descriptor(HUGE_EXPONENT)
    with pytest.raises(DeviceError, match="no physical size for X"):
        ReportStream(desc, "pen")
    assert ReportStream(desc, "pen", (0.1, 0.05)).surface_size == (0.1, 0.05)


def test_thousands_of_fields_compile_to_one_flat_decoder() -> None:
    (report,) = parse_descriptor(MANY_FIELDS).input_reports.values()
    decoder = ReportDecoder(report)
    values = decoder.decode(b"\xff" * decoder.byte_size)
    assert len(values) == 2 * MAX_REPORT_COUNT and set(values) == {1}


def test_a_usage_range_is_clamped_like_the_kernels() -> None:
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    (report,) = parse_descriptor(HUGE_RANGE).input_reports.values()
    (field,) = report.fields
    assert len(field.usages) == MAX_REPORT_COUNT
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100_000  # KiB


@pytest.mark.parametrize("raw", [HUGE_EXPONENT, MANY_FIELDS, HUGE_RANGE])
def test_hid_describe_and_decode_answer_without_a_traceback(tmp_path: Path, raw: bytes) -> None:
    rec = tmp_path / "hostile.hid"
    rec.write_text(f"N: hostile\nI: 3 1234 5678\nR: {len(raw)} {raw.hex(' ')}\nE: 0.0 1 00\n")
    for cmd in ("describe", "decode"):
        done = subprocess.run(
            [sys.executable, "-m", "stiction", "hid", cmd, str(rec), "--json"],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert "Traceback" not in done.stderr, done.stderr
        assert done.returncode == 0, done.stderr
