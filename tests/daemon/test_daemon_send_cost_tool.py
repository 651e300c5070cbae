"""tools/zmq_send_cost.py, whose figures docs/daemon.md quotes, runs and prints
every way of spending the spin, each with its first and second send."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_send_cost_tool_prints_a_row_per_way() -> None:
    done = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "zmq_send_cost.py"),
            "--ticks",
            "5",
            "--subscribers",
            "2",
            "--rounds",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].split()[:2] == ["way", "first"]
    rows = {line.split()[0]: line.split()[1:] for line in lines[1:4]}
    assert list(rows) == ["none", "void", "inproc"]
    for cells in rows.values():
        numbers = [float(c) for c in cells[:6]]
        assert all(0 < x < 100_000 for x in numbers)  # microseconds
        assert cells[6].endswith("x")
    assert "2 subscribers, 1 x 5 deadlines per way" in lines[4]
