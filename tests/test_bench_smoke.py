"""Every benchmark runs, in a tiny configuration, so a refactor cannot break one unnoticed.

Each runs as `stiction bench NAME` in a subprocess (the CLI loads bench/NAME.py by
path, exactly as a user would run it) with STICTION_BENCH_RESULTS pointing at
tmp_path: bench/results/ holds the committed figures the docs quote, and must come
out byte for byte unchanged. Only the shape of the results is checked; timings
from a run this small mean nothing and are never asserted.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import NamedTuple

import pytest

from stiction.cli import bench_dir

pytestmark = pytest.mark.slow

COMMITTED = bench_dir() / "results"


class Smoke(NamedTuple):
    args: tuple[str, ...]  # the tiny configuration
    stem: str  # results are written to <stem>.{txt,json[,png]}
    png: bool
    keys: frozenset[str]  # top-level keys of <stem>.json
    data: str | None = None  # conftest fixture the benchmark's recordings come from


SMOKES = {
    "accuracy": Smoke(
        ("--quick", "--contacts", "100"),
        "accuracy",
        True,
        frozenset(
            {
                "settings",
                "reference_check",
                "follow_every_sample",
                "batch_contacts",
                "loop_ns_per_contact_step",
                "steady_slide_us_per_step",
                "targets",
            }
        ),
    ),
    "clients": Smoke(
        ("--frames", "200", "--pages", "2"),
        "clients",
        False,
        frozenset({"read_us_per_frame", "transcode_us_per_frame"}),
    ),
    "daemon": Smoke(
        # 1 s is the shortest run with latency figures (the first 0.5 s is dropped).
        ("--seconds", "1", "--idle-seconds", "1", "--subscribers", "2"),
        "daemon-1s",
        True,
        frozenset({"bare", "raw", "daemon", "idle", "targets", "mode", "steal_pct"}),
    ),
    "evdev": Smoke(
        ("--repeat", "1"),
        "evdev",
        True,
        frozenset({"recordings", "pooled", "ratio_naive_over_stiction", "repeat"}),
        data="evdev_data",
    ),
    "hid": Smoke(
        ("--repeat", "1", "--sample", "20"),
        "hid",
        True,
        frozenset({"recordings", "ratio", "us_per_report", "batch_reports_per_s", "targets"}),
        data="hid_data",
    ),
    "scene": Smoke(("--quick",), "scene", True, frozenset({"rows", "quick"})),
}


def _hashes(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def test_every_benchmark_has_a_smoke_run() -> None:
    names = {p.stem for p in bench_dir().glob("*.py") if not p.stem.startswith("_")}
    assert names == set(SMOKES)


@pytest.mark.parametrize("name", sorted(SMOKES))
def test_bench_smoke(name: str, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    smoke = SMOKES[name]
    if smoke.data:
        request.getfixturevalue(smoke.data)  # fails clearly if shared/ is missing
    before = _hashes(COMMITTED)
    out = tmp_path / "results"
    # The daemon benchmark leaves its sockets in a mkdtemp() folder: keep it out
    # of /tmp. Short, since ipc:// paths are limited to ~100 characters.
    with tempfile.TemporaryDirectory(prefix="sb-") as scratch:
        env = {**os.environ, "STICTION_BENCH_RESULTS": str(out), "TMPDIR": scratch}
        run = subprocess.run(
            [sys.executable, "-m", "stiction", "bench", name, *smoke.args, "--json"],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert run.returncode == 0, run.stderr[-3000:]
    assert _hashes(COMMITTED) == before, "a benchmark wrote to bench/results/"

    expected = {f"{smoke.stem}.txt", f"{smoke.stem}.json"}
    if smoke.png:
        expected.add(f"{smoke.stem}.png")
    assert {p.name for p in out.iterdir()} == expected
    assert (out / f"{smoke.stem}.txt").read_text().strip()
    result = json.loads((out / f"{smoke.stem}.json").read_text())
    assert smoke.keys <= result.keys()
    if smoke.png:
        assert (out / f"{smoke.stem}.png").read_bytes().startswith(b"\x89PNG")
    # --json prints JSON (accuracy, scene: one object per setting or row and line).
    lines = run.stdout.splitlines() if name in ("accuracy", "scene") else [run.stdout]
    assert lines and all(json.loads(line) for line in lines)
