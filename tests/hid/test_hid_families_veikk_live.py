"""The VEIKK 13-byte family on the live path: production hidraw backend against umockdev.

A VEIKK VK640 (2feb:0005, the catalogue's ``veikk-vk-tilt`` entry) is mocked
with a vendor interface declaring its 13-byte report 9. The reports are BUILT
from the layout (no recording of this tablet exists in ../shared/data/hid);
one frame report is REAL, from the dump in OpenTabletDriver issue #3924.
umockdev's script sends the reports only after the program wrote the three
output reports the catalogue entry gives, so the test also shows that the
vendor-mode switch happens before reading.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pytest
from test_hid_umockdev import _run
from umockdev_hidraw import write_mock

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import lookup
from stiction.drivers.hid.stream import ReportStream

pytestmark = pytest.mark.umockdev

# Usage Page 0xff0a, Usage 1, Collection (Application), Report ID 9, 12 bytes
# of vendor data (a 13-byte report), End Collection.
VENDOR_13 = bytes.fromhex("060aff0901a1018509750895 0c150026ff0009018102c0".replace(" ", ""))
FRAME = bytes.fromhex("09 42 03 00 01 00 00 00 00 00 00 02 07")  # issue #3924


def _vk(x: int, y: int, p: int, flags: int = 0x20) -> bytes:
    return (
        bytes([0x09, 0x41, flags])
        + x.to_bytes(3, "little")
        + y.to_bytes(3, "little")
        + p.to_bytes(2, "little")
        + bytes([0xF6, 0x05])
    )


def test_a_vk640_is_switched_to_its_vendor_mode_and_read_through_hidraw(tmp_path: Path) -> None:
    entry = lookup(0x2FEB, 0x0005, descriptor=VENDOR_13)
    assert entry is not None and entry.family == "veikk-vk-tilt" and entry.descriptor
    writes = [data for kind, data in entry.init_reports if kind == "output"]
    assert writes == [bytes.fromhex(h) for h in ("090104", "090202", "090302")]
    reports = [_vk(1000 + 200 * i, 500 + 100 * i, 300 * max(0, i - 20)) for i in range(60)]
    reports.insert(30, FRAME)
    reports.append(_vk(13000, 6500, 0, 0xC0))
    files = write_mock(
        tmp_path, "VEIKK VK640", 0x2FEB, 0x0005, VENDOR_13, reports, expect_writes=writes
    )
    lines = _run(tmp_path, files, len(reports))
    head = next(x for x in lines if "kind" in x)
    assert head["size"] == pytest.approx([0.1524, 0.1016])
    tail = lines[-1]
    assert tail["error"] is None and tail["stats"]["reports"] == len(reports)
    assert tail["stats"]["ignored"] == 1  # the frame report

    stream = ReportStream(parse_descriptor(entry.descriptor), entry.name, None, entry)
    expected = [asdict(s) for i, r in enumerate(reports) for s in stream.feed(float(i), r)]
    got = [x for x in lines if "x" in x]
    assert len(got) == len(expected) == 61
    for g, e in zip(got, expected, strict=True):
        for key in ("x", "y", "tip", "in_range", "pressure"):
            assert g[key] == pytest.approx(e[key]), key
    assert sum(g["tip"] for g in got) == 39 and got[-1]["in_range"] is False
