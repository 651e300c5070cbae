"""Every benchmark runs, in a tiny configuration, so a refactor cannot break one unnoticed.

Each runs as `stiction bench NAME` in a subprocess (the CLI imports
stiction.bench.NAME, exactly as for a user who installed the package) with its
results folder in tmp_path (half of them by --out, half by
STICTION_BENCH_RESULTS): bench/results/ holds the committed figures the docs
quote, and must come out byte for byte unchanged. Only the shape of the results is checked; timings
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

import stiction.bench
from stiction import cli
from stiction.bench import _support
from stiction.errors import StictionError

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[1]
COMMITTED = REPO / "bench" / "results"


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
    "devices": Smoke(
        ("--limit", "6"),
        "devices",
        False,
        frozenset({"new", "descriptor_only", "by_driver", "by_kind", "devices", "recordings"}),
        data="coverage_data",
    ),
    "evdev": Smoke(
        ("--repeat", "1"),
        "evdev",
        True,
        frozenset({"recordings", "pooled", "ratio_naive_over_stiction", "repeat"}),
        data="evdev_data",
    ),
    "faults": Smoke(
        ("--seconds", "2"),
        "faults",
        False,
        frozenset({"crashes", "hangs", "frames_accounted", "rss_growth_pct", "targets"}),
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
    assert set(stiction.bench.names()) == set(SMOKES)


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
        env = {**os.environ, "TMPDIR": scratch}
        by_flag = sorted(SMOKES).index(name) % 2 == 0
        if by_flag:
            env.pop("STICTION_BENCH_RESULTS", None)
            where = ["--out", str(out)]
        else:
            env["STICTION_BENCH_RESULTS"] = str(out)
            where = []
        run = subprocess.run(
            [sys.executable, "-m", "stiction", "bench", name, *where, *smoke.args, "--json"],
            env=env,
            capture_output=True,
            text=True,
            # A guard against a hang, not a speed check: the daemon benchmark
            # compiles numba's tick twice into fresh caches, which a loaded
            # 2-CPU machine has been seen to stretch past two minutes.
            timeout=600,
        )
    assert run.returncode == 0, run.stderr[-3000:]
    assert _hashes(COMMITTED) == before, "a benchmark wrote to bench/results/"

    expected = {f"{smoke.stem}.txt", f"{smoke.stem}.json"}
    if smoke.png:
        expected.add(f"{smoke.stem}.png")
    assert {p.name for p in out.iterdir()} == expected
    # It says where it wrote, on stderr (stdout is the benchmark's own).
    assert f"wrote {', '.join(sorted(expected))} in {out}" in run.stderr
    assert (out / f"{smoke.stem}.txt").read_text().strip()
    result = json.loads((out / f"{smoke.stem}.json").read_text())
    assert smoke.keys <= result.keys()
    if smoke.png:
        assert (out / f"{smoke.stem}.png").read_bytes().startswith(b"\x89PNG")
    # --json prints JSON (accuracy, scene: one object per setting or row and line).
    lines = run.stdout.splitlines() if name in ("accuracy", "scene") else [run.stdout]
    assert lines and all(json.loads(line) for line in lines)


def _bench(args: list[str], env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "stiction", "bench", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_default_results_go_to_the_user_cache_not_the_checkout(tmp_path: Path) -> None:
    """No flag, no STICTION_BENCH_RESULTS: $XDG_CACHE_HOME/stiction/bench, and it says so."""
    env = {k: v for k, v in os.environ.items() if k != "STICTION_BENCH_RESULTS"}
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")
    before = _hashes(COMMITTED)
    run = _bench(["scene", "--quick"], env)
    assert run.returncode == 0, run.stderr[-3000:]
    out = tmp_path / "cache" / "stiction" / "bench"
    assert {p.name for p in out.iterdir()} == {"scene.txt", "scene.json", "scene.png"}
    assert f"in {out}" in run.stderr
    assert _hashes(COMMITTED) == before


def test_save_refuses_a_quick_run(tmp_path: Path) -> None:
    before = _hashes(COMMITTED)
    run = _bench(["scene", "--save", "--quick"], dict(os.environ))
    assert run.returncode == 2
    assert "--save" in run.stderr and "--quick" in run.stderr
    assert "Traceback" not in run.stderr
    assert _hashes(COMMITTED) == before


def test_save_outside_a_checkout_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    """An installed package has no bench/results/ to save into: one line, exit 2."""
    monkeypatch.setattr(_support, "source_checkout", lambda: None)
    with pytest.raises(StictionError, match=r"--save .*source checkout.*--out DIR"):
        _support.committed_results()


def test_save_targets_the_checkouts_committed_results() -> None:
    assert _support.committed_results() == COMMITTED


def test_out_and_save_exclude_each_other(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["bench", "--out", "/nonexistent", "scene", "--save"]) == 2
    assert "--out and --save" in capsys.readouterr().err


def test_missing_bench_extra_names_the_install_command(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Without the extra's modules: one line naming pip install 'stiction[bench]', exit 2."""
    monkeypatch.setattr(_support, "EXTRA_MODULES", ("stiction_no_such_module", "tqdm"))
    assert cli.main(["bench", "scene", "--out", str(tmp_path), "--quick"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "stiction_no_such_module" in err and "pip install 'stiction[bench]'" in err
    assert not any(tmp_path.iterdir())


def test_the_wheel_ships_the_benchmarks(tmp_path: Path) -> None:
    """`pip install .` then `stiction bench` works outside the checkout (issue 13).

    The wheel is built from this checkout and unpacked (it is pure Python, so
    that is what installing it does); its stiction is imported from there, with
    the dependencies of this environment, from a folder outside the checkout.
    """
    wheels = tmp_path / "wheels"
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(REPO)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert build.returncode == 0, build.stderr[-3000:]
    (wheel,) = wheels.glob("stiction-*.whl")
    site = tmp_path / "site"
    import zipfile

    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        zf.extractall(site)
    assert {f"stiction/bench/{n}.py" for n in SMOKES} <= set(names)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "STICTION_BENCH_RESULTS"}
    env.update(PYTHONPATH=str(site), XDG_CACHE_HOME=str(tmp_path / "cache"))
    where = subprocess.run(
        [sys.executable, "-c", "import stiction; print(stiction.__file__)"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
    )
    assert where.stdout.startswith(str(site)), where
    run = subprocess.run(
        [sys.executable, "-m", "stiction", "bench", "scene", "--quick"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,  # the installed copy compiles its kernels into a fresh cache
    )
    assert run.returncode == 0, run.stderr[-3000:]
    out = tmp_path / "cache" / "stiction" / "bench"
    assert (out / "scene.json").is_file() and f"in {out}" in run.stderr
    # An installed package has no committed figures to overwrite.
    save = subprocess.run(
        [sys.executable, "-m", "stiction", "bench", "scene", "--save"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert save.returncode == 2 and "source checkout" in save.stderr
