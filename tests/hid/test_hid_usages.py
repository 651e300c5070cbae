"""Usage names in `hid describe` and `hid decode`, and the two agreeing on usage keys."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import hidtools.hut as hut
import pytest

from stiction.drivers.hid.usages import usage_hex, usage_name

# Usages a pen, touch screen or touchpad report is read by; hid-tools' HUT must agree.
CORE = [
    0x00010030, 0x00010031, 0x00010038, 0x000D0042, 0x000D0044, 0x000D0045, 0x000D0032,
    0x000D0030, 0x000D003C, 0x000D003D, 0x000D003E, 0x000D0054, 0x000D0056, 0x000D0022,
    0x000D0002, 0x000D0004, 0x000D0005, 0x000D005A, 0x000D0048, 0x000D0049,
]  # fmt: skip


@pytest.mark.parametrize("usage", CORE)
def test_names_agree_with_hid_tools(usage: int) -> None:
    page, uid = usage >> 16, usage & 0xFFFF
    assert usage_name(usage).split(" / ")[1].lower() == str(hut.HUT[page][uid]).lower()


def test_buttons_vendor_pages_and_unknown_usages() -> None:
    assert usage_name(0x00090003) == "Button / Button 3"
    assert usage_name(0xFF000001) == "Vendor 0xFF00 / 0x0001"
    assert usage_name(0x000D0099) == "Digitizers / 0x0099"
    assert usage_name(0xFF0D0042) == "Wacom (vendor) / Tip Switch"
    assert usage_hex(0x000D0042) == "0x000d0042"


def _stiction(*args: str) -> list[str]:
    done = subprocess.run(
        [sys.executable, "-m", "stiction", *args], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


def test_describe_and_decode_use_the_same_usage_keys_and_names(hid_data: Path) -> None:
    rec = str(hid_data / "xp-pen-artist-10s.hid")
    (describe,) = _stiction("hid", "describe", rec, "--json")
    fields = [f for r in json.loads(describe)["input_reports"] for f in r["fields"]]
    for f in fields:  # the keys architecture.md promises are all still there
        assert {"usage", "bit_offset", "bit_size", "count", "unit", "variable"} <= set(f)
        assert f["usage_hex"] == f"0x{f['usage']:08x}"
    described = {f["usage_hex"]: f["usage_name"] for f in fields}
    decoded = json.loads(_stiction("hid", "decode", rec, "--json")[0])
    assert set(decoded["fields"]) <= set(described)
    assert all(decoded["names"][k] == described[k] for k in decoded["fields"])


def test_text_output_names_usages(hid_data: Path) -> None:
    rec = str(hid_data / "xp-pen-artist-10s.hid")
    line = _stiction("hid", "decode", rec)[0]
    assert "Tip Switch=" in line and "X=" in line and "0x000d0042" not in line
    text = "\n".join(_stiction("hid", "describe", rec))
    assert "Digitizers / Tip Switch" in text and "(Digitizers / Pen)" in text
