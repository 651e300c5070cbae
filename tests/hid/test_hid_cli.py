"""`stiction hid describe|decode`: the formats architecture.md promises, checked on real data."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.cli import main


def _lines(capsys: pytest.CaptureFixture[str], *argv: str) -> list[dict]:  # type: ignore[type-arg]
    assert main(list(argv)) == 0
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


def test_describe_json_shape(hid_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (out,) = _lines(capsys, "hid", "describe", str(hid_data / "huion-hs610.hid"), "--json")
    (report,) = out["input_reports"]
    assert (report["report_id"], report["bit_size"]) == (10, 80)
    keys = {
        "usage",
        "bit_offset",
        "bit_size",
        "count",
        "logical_min",
        "logical_max",
        "physical_min",
        "physical_max",
        "unit",
        "unit_exponent",
        "variable",
        "constant",
        "relative",
        "usage_hex",
        "usage_name",
    }
    assert all(set(f) == keys for f in report["fields"])
    x = next(f for f in report["fields"] if f["usage"] == 0x00010030)
    assert (x["bit_offset"], x["bit_size"], x["unit"], x["unit_exponent"]) == (16, 16, 0x33, -3)
    # a variable item is one field per usage: Invert repeats three times
    assert [f["usage"] for f in report["fields"]].count(0x000D003C) == 3


def test_decode_json_lines(hid_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = hid_data / "ugee-m708-v2.hid"
    lines = _lines(capsys, "hid", "decode", str(path), "--json")
    assert len(lines) == 3484
    first = lines[0]
    assert set(first) == {"time", "report_id", "fields", "names", "contacts"}
    assert first["names"]["0x00010030"] == "Generic Desktop / X"
    assert first["time"] == 0.0 and first["report_id"] == 7
    assert all(re.fullmatch(r"0x[0-9a-f]{8}", k) for k in first["fields"])
    from stiction.drivers.hid.recording import load_recording

    data = load_recording(path).events[0].data
    assert first["fields"]["0x00010030"] == [int.from_bytes(data[2:4], "little")]
    assert first["fields"]["0x00010031"] == [int.from_bytes(data[4:6], "little")]
    (c,) = first["contacts"]
    assert 0 <= c["x"] <= 0.2539746 and 0 <= c["y"] <= 0.1523746
    assert {"contact", "tip", "in_range", "pressure", "tool"} <= set(c)


def test_decode_without_size_prints_null_contacts_and_warns_once(
    hid_data: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["hid", "decode", str(hid_data / "huion-hs610.hid"), "--json"]) == 0
    captured = capsys.readouterr()
    lines = [json.loads(x) for x in captured.out.splitlines()]
    assert all(line["contacts"] is None for line in lines)
    assert captured.err.count("warning") == 1 and "--size-mm WxH" in captured.err
    lines = _lines(
        capsys,
        "hid",
        "decode",
        str(hid_data / "huion-hs610.hid"),
        "--json",
        "--size-mm",
        "254x158.75",
    )
    assert sum(len(line["contacts"]) for line in lines) == 2527
    tilts = [v for line in lines for v in line["fields"]["0x000d003d"]]
    assert min(tilts) < 0 < max(tilts)  # sign-extended (logical minimum -127)


def test_bad_size_argument_is_a_usage_error(hid_data: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "stiction",
            "hid",
            "decode",
            str(hid_data / "veikk-s640.hid"),
            "--size",
            "big",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert "WIDTHxHEIGHT" in proc.stderr and "Traceback" not in proc.stderr


def test_decode_prints_huge_fields_as_hex(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 32752-bit field (found by fuzzing) must not break JSON output (no 4300-digit ints)."""
    raw = bytes.fromhex("05 0d 09 02 a1 01 85 35 75 08 96 fe 0f 19 35 81 02 c0")
    report = b"\x35" + b"\xff" * 4094
    f = tmp_path / "huge.hid"
    f.write_text(
        f"N: huge\nI: 3 1 2\nR: {len(raw)} {raw.hex(' ')}\nE: 0.0 {len(report)} {report.hex(' ')}\n"
    )
    (line,) = _lines(capsys, "hid", "decode", str(f), "--json")
    (value,) = line["fields"]["0x000d0035"]
    assert value == hex((1 << 32752) - 1)


@pytest.mark.parametrize("kind", ["file", "fifo", "directory", "/dev/zero"])
def test_hid_read_of_something_that_is_not_hidraw_says_so(
    tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """hidapi 'opened' these and said 'open failed', explained as a missing udev rule."""
    import os

    path = tmp_path / "node"
    if kind == "file":
        path.write_bytes(b"\x00" * 64)
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    else:
        path = Path(kind)
    assert main(["hid", "read", str(path), "--count", "1"]) == 2
    err = capsys.readouterr().err
    assert f"{path} is not a hidraw device" in err and "udev" not in err
