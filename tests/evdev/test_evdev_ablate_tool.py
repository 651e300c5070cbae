"""tools/ablate_evdev_reader.py, whose figures docs/evdev.md quotes, runs and compares
each variant with the reader on every recording."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_ablation_tool_prints_every_variant_for_every_recording() -> None:
    done = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "ablate_evdev_reader.py"), "--repeat", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].split()[1:] == ["reader", "same", "no-snapshot", "no-frame-count"]
    assert len(lines) == 1 + 8 + 2  # header, recordings, pooled, difference
    pooled = [float(x) for x in lines[-2].split()[-4:]]
    assert all(0 < x < 50 for x in pooled)  # microseconds per frame
    assert lines[-1].split()[-4] == "+0.0%"
