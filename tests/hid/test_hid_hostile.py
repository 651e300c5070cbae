"""Descriptors the kernel would accept that used to exhaust stiction (issue 12).

Each is a few bytes; each crashed or exhausted `stiction devices`, `doctor`
and `hid decode` before: a 4-byte Unit Exponent (OverflowError converting
the size), thousands of variable fields (RecursionError compiling the
decoder), an array whose usage range spans 2^32 usages (MemoryError).
"""

from __future__ import annotations

import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

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


@pytest.mark.umockdev
def test_a_hostile_node_beside_a_tablet_is_reported_alone(tmp_path: Path, hid_data: Path) -> None:
    """`stiction devices` through the real hidapi backend with two mocked hidraw nodes."""
    import json
    import shutil

    from umockdev_hidraw import write_mock

    from stiction.drivers.hid.recording import load_recording

    exe = shutil.which("umockdev-run")
    if exe is None:
        pytest.fail("umockdev-run is not installed (Debian package umockdev)")
    rec = load_recording(hid_data / "xp-pen-artist-10s.hid")
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    hostile = write_mock(tmp_path / "a", "hostile", 0x1234, 0x5678, HUGE_EXPONENT, [], num=5)
    tablet = write_mock(tmp_path / "b", rec.name, rec.vid, rec.pid, rec.descriptor, [], num=6)
    cmd = [exe]
    for files in (hostile, tablet):
        cmd += ["--device", str(files.device), "--ioctl", f"{files.dev_node}={files.ioctl}"]
    cmd += ["--", sys.executable, "-m", "stiction", "devices", "--json"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    found = {d["path"]: d for d in json.loads(done.stdout)}
    assert found[tablet.dev_node]["problem"] is None
    assert "no physical size" in found[hostile.dev_node]["problem"]


def test_a_probe_that_fails_unexpectedly_is_one_devices_problem(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from stiction.drivers.hid import hidraw_backend

    nodes = [
        {"path": b"/dev/hidraw1", "vendor_id": 1, "product_id": 2, "product_string": "odd"},
        {"path": b"/dev/hidraw2", "vendor_id": 3, "product_id": 4, "product_string": "fine"},
    ]

    def probe(d: dict) -> hidraw_backend.DeviceInfo:  # type: ignore[type-arg]
        if d["path"] == b"/dev/hidraw1":
            raise ZeroDivisionError("a bug")
        return hidraw_backend.DeviceInfo("/dev/hidraw2", "hidraw", 3, 4, "fine", "pen", None)

    monkeypatch.setattr(hidraw_backend, "_enumerate", lambda: nodes)
    monkeypatch.setattr(hidraw_backend, "_probe", probe)
    odd, fine = hidraw_backend.discover()
    assert odd.kind == "unknown" and "ZeroDivisionError" in (odd.problem or "")
    assert fine.problem is None


_REAL = Path(__file__).resolve().parents[3] / "shared/data/hid/xp-pen-artist-10s.hid"


@given(
    edits=st.lists(
        st.tuples(st.integers(0, 40), st.sampled_from(["E:", "R:", "I:", "N:", "D:", "#"]),
                  st.text(max_size=40)),
        max_size=4,
    )
)  # fmt: skip
def test_any_edited_hid_recorder_file_is_a_recording_or_one_error(
    edits: list[tuple[int, str, str]],
) -> None:
    """Real lines with a few replaced by arbitrary ones of a known tag, so the
    parser gets past the first line before it meets them."""
    from stiction.drivers.hid.recording import parse_recording
    from stiction.errors import StictionError

    lines = _REAL.read_text().splitlines()[:60] if _REAL.is_file() else ["R: 0"]
    for i, tag, text in edits:
        lines[min(i, len(lines) - 1)] = f"{tag} {text}"
    try:
        parse_recording("\n".join(lines), "r.hid")
    except StictionError as exc:
        assert "\n" not in str(exc)


# The same pen with a physical extent no surface has: 0..2147483647 cm, and 0..1 at
# Unit Exponent -4 (one micrometre).
HUGE_EXTENT = _h(
    "050d 0902 a101 8501 0920 a100 0501 5500 6511 3500 47ffffff7f"
    " 0930 0931 1500 26ff00 7510 9502 8102 c0 c0"
)
TINY_EXTENT = _h(
    "050d 0902 a101 8501 0920 a100 0501 550c 6511 3500 4501"
    " 0930 0931 1500 26ff00 7510 9502 8102 c0 c0"
)


@pytest.mark.parametrize(
    ("raw", "claimed"), [(HUGE_EXTENT, "2.14748e+07 m"), (TINY_EXTENT, "1e-06 m")]
)
def test_a_size_no_surface_has_is_taken_as_none(raw: bytes, claimed: str) -> None:
    """A descriptor claiming a 21,475 km (or 1 um) pen area moved the pointer by
    nothing (or by everything); it now asks for the size, quoting what it claimed."""
    desc = parse_descriptor(raw)
    with pytest.raises(DeviceError, match=re.escape(f"a physical size no surface has ({claimed})")):
        ReportStream(desc, "pen")
    assert ReportStream(desc, "pen", (0.1, 0.05)).surface_size == (0.1, 0.05)
