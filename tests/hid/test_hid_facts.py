"""`hid describe`'s device object: kind, surface, where the size came from, and the problem."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.drivers.hid.playback import open_replay


def _describe(path: Path, env: dict[str, str] | None = None) -> dict[str, object]:
    import os

    done = subprocess.run(
        [sys.executable, "-m", "stiction", "hid", "describe", str(path), "--json"],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, **(env or {})},
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert "input_reports" in out  # every key the JSON had stays
    return dict(out["device"])


@pytest.mark.parametrize(
    ("name", "kind", "size_from", "surface"),
    [
        ("ugee-m708-v2", "pen", "descriptor", (0.254, 0.1524)),
        ("veikk-s640", "pen", "catalogue", (0.1524, 0.1016)),
        ("wacom-penpartner", "pen", "catalogue", (0.065, 0.0464)),
        ("huion-hs610", "pen", "vendor-init", None),
        ("elan-04f3-3140-touchpad", "touchpad", "descriptor", (0.1019, 0.0665)),
        ("contour-rollermouse-red", None, None, None),
    ],
)
def test_device_object_says_kind_surface_and_where_the_size_came_from(
    hid_data: Path, name: str, kind: str | None, size_from: str | None, surface: object
) -> None:
    d = _describe(hid_data / f"{name}.hid")
    assert set(d) == {"kind", "surface_m", "size_from", "catalogue", "backend", "problem"}
    assert (d["kind"], d["size_from"], d["backend"]) == (kind, size_from, "hidraw")
    if surface is None:
        assert d["surface_m"] is None
    else:
        assert d["surface_m"] == pytest.approx(surface, abs=1e-4)
    assert (d["problem"] is None) == (kind is not None)


def test_a_users_own_entry_is_config_and_wins(hid_data: Path, tmp_path: Path) -> None:
    table = tmp_path / "mine.toml"
    table.write_text('[[device]]\nid = "28bd:0907"\nsource = "my ruler"\nsize_mm = [250, 150]\n')
    d = _describe(hid_data / "ugee-m708-v2.hid", {"STICTION_HID_DEVICES": str(table)})
    assert d["size_from"] == "config" and d["surface_m"] == pytest.approx([0.25, 0.15])


def test_the_table_wins_over_the_descriptor_on_a_real_recording(hid_data: Path) -> None:
    """XP-Pen Deco 03: the table's size (XP-Pen's 10 x 5.62 in) is what its recorded
    pen positions are scaled to, not the descriptor's."""
    d = _describe(hid_data / "xp-pen-deco-03.hid")
    assert d["size_from"] == "catalogue"
    src = open_replay(hid_data / "xp-pen-deco-03.hid")
    assert src.surface_size == pytest.approx((0.254, 0.1427))
    samples = list(src.samples())
    assert samples and all(0 <= s.x <= 0.254 and 0 <= s.y <= 0.1427 for s in samples)
