"""`stiction experiment simulate` through the real daemon: its files, and a killed run resumed."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.cli import main
from stiction.experiment import data

STICTION = [sys.executable, "-m", "stiction"]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[2] / "src")
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    return env


def test_simulate_writes_the_files_of_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["experiment", "simulate", "paper-study2", "--repetitions", "1", "--participants", "1"]
    assert main([*argv, "--out", str(tmp_path), "--seed", "4", "--record"]) == 0
    assert "simulated 1 participant(s) of paper-study2 (7 trials each)" in capsys.readouterr().out
    rows = data.read_trials([tmp_path / "sim01.csv"])
    assert [r["trial"] for r in rows] == list(range(1, 8))
    assert sorted(r["comparison_mu_s"] for r in rows) == [0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]
    for r in rows:
        assert r["method"] == "ratio" and r["standard_mu_s"] == 0.7 and r["string"] == 1
        assert r["max_string_length_px"] > 0 and r["stroke_speed_px_s"] > 0
        assert r["response_time_s"] > 0
    side = json.loads((tmp_path / "sim01.json").read_text())
    for key in ("software", "study", "seed", "device", "device_size_m", "display", "scene",
                "start_time", "end_time", "daemon_version", "rate_hz"):  # fmt: skip
        assert side.get(key) is not None, key
    assert side["device"] == "synthetic-stdin" and side["rate_hz"] == 100.0
    assert side["scene"]["display"] == [2880, 1800]
    frames = [json.loads(line) for line in (tmp_path / "sim01.frames.jsonl").open()]
    assert {(f["trial"], f["stimulus"]) for f in frames} == {
        (t, s) for t in range(1, 8) for s in (1, 2)
    }


def test_simulate_refuses_bad_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(
            [
                "experiment",
                "simulate",
                "paper-study1",
                "--participants",
                "0",
                "--out",
                str(tmp_path),
            ]
        )
    assert info.value.code == 2
    assert "must be at least 1" in capsys.readouterr().err
    assert main(["experiment", "simulate", "paper-study9", "--participants", "1",
                 "--out", str(tmp_path)]) == 2  # fmt: skip
    assert "no such study file" in capsys.readouterr().err


def test_a_killed_run_resumes_where_it_stopped(tmp_path: Path) -> None:
    """SIGKILL mid-study (no chance to clean up), then the same command again."""
    cmd = [*STICTION, "experiment", "simulate", "paper-study1", "--repetitions", "1",
           "--participants", "1", "--out", str(tmp_path), "--seed", "9"]  # fmt: skip
    csv = tmp_path / "sim01.csv"
    proc = subprocess.Popen(cmd, env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        # wait for a few complete rows: each is on disk when its answer is given
        for _ in range(100_000):
            if csv.exists() and csv.read_text().count("\n") >= 4:
                break
            assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
    before = data.read_trials([csv])
    assert 3 <= len(before) < 12
    done = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    after = data.read_trials([csv])
    assert [r["trial"] for r in after] == list(range(1, 13))
    assert after[: len(before)] == before  # the trials done before the crash are kept as they were
    side = json.loads((tmp_path / "sim01.json").read_text())
    assert len(side["resumed"]) == 1 and side["end_time"] is not None
    # a complete participant is left alone
    again = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=300)
    assert again.returncode == 0
    assert data.read_trials([csv]) == after


def test_run_without_a_daemon_is_one_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    endpoint = f"ipc://{tmp_path}/nothing"
    argv = ["experiment", "run", "paper-study1", "--participant", "P01", "--out", str(tmp_path),
            "--pub", endpoint, "--control", endpoint, "--port", "0"]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "no reply to 'ping'" in err and "Traceback" not in err
    assert main([*argv[:4], "../P01", *argv[5:]]) == 2
    assert "participant ID '../P01'" in capsys.readouterr().err
