"""Every command given a file it may not read (or a folder it may not write) says so in one line.

Tests run as root in CI, and root reads a mode-000 file anyway. So as root
each command runs under `setpriv` without CAP_DAC_OVERRIDE and
CAP_DAC_READ_SEARCH: still uid 0, but file modes apply to it as to anyone.
As a normal user the modes apply already and the command runs as it is.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.scene.load import example_path

ROOT_WITHOUT_OVERRIDE = [
    "setpriv",
    "--bounding-set=-dac_override,-dac_read_search",
    "--inh-caps=-dac_override,-dac_read_search",
]

pytestmark = pytest.mark.skipif(
    os.geteuid() == 0 and shutil.which("setpriv") is None,
    reason="as root, file modes bind only without CAP_DAC_OVERRIDE, which needs setpriv",
)

EXAMPLE_TRACE = Path(__file__).resolve().parents[1] / "src/stiction/sim/examples/stroke.csv"


def _run(argv: list[str], module: str = "stiction") -> subprocess.CompletedProcess[str]:
    prefix = ROOT_WITHOUT_OVERRIDE if os.geteuid() == 0 else []
    return subprocess.run(
        [*prefix, sys.executable, "-m", module, *argv],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def _locked(path: Path, content: bytes) -> Path:
    path.write_bytes(content)
    path.chmod(0)
    return path


@pytest.mark.parametrize(
    "case",
    [
        "simulate",
        "simulate --scene",
        "stictiond --config",
        "stictiond --scene",
        "replay",
        "trace",
        "hid describe",
        "evdev decode",
        "experiment check",
        "listen --curve",
    ],
)
def test_an_unreadable_file_is_one_line_naming_it(tmp_path: Path, case: str) -> None:
    scene = example_path("demo").read_bytes()
    module = "stiction"
    if case == "simulate":
        f = _locked(tmp_path / "t.csv", EXAMPLE_TRACE.read_bytes())
        argv = ["simulate", str(f), "--out", str(tmp_path / "o.csv")]
    elif case == "simulate --scene":
        f = _locked(tmp_path / "s.toml", scene)
        argv = ["simulate", "example:stroke", "--out", str(tmp_path / "o.csv"), "--scene", str(f)]
    elif case == "stictiond --config":
        f = _locked(tmp_path / "c.toml", b"[daemon]\nrate = 100\n")
        argv, module = ["--config", str(f)], "stiction.daemon.main"
    elif case == "stictiond --scene":
        f = _locked(tmp_path / "s.toml", scene)
        argv, module = ["--scene", str(f)], "stiction.daemon.main"
    elif case == "replay":
        f = _locked(tmp_path / "r.npz", b"PK\x03\x04")
        argv = ["replay", str(f), "--no-wait"]
    elif case == "trace":
        f = _locked(tmp_path / "r.hid", b"R: 1 05\n")
        argv = ["trace", str(f), "--out", str(tmp_path / "t.csv")]
    elif case == "hid describe":
        f = _locked(tmp_path / "r.hid", b"R: 1 05\n")
        argv = ["hid", "describe", str(f)]
    elif case == "evdev decode":
        f = _locked(tmp_path / "r.evemu", b"N: pen\n")
        argv = ["evdev", "decode", str(f)]
    elif case == "experiment check":
        f = _locked(tmp_path / "study.toml", b"[study]\n")
        argv = ["experiment", "check", str(f)]
    else:
        f = _locked(tmp_path / "k.key", b"")
        argv = ["listen", "ipc:///nonexistent", "--no-control", "--seconds", "0.1"]
        argv += ["--curve-server-key", str(f), "--curve-client-key", str(f)]
    done = _run(argv, module)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert str(f) in done.stderr and "Permission denied" in done.stderr, done.stderr


def test_keys_into_a_folder_that_cannot_be_written_is_one_line(tmp_path: Path) -> None:
    folder = tmp_path / "keys"
    folder.mkdir(mode=0o555)
    done = _run(["keys", str(folder), "daemon"])
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "Permission denied" in done.stderr and "Traceback" not in done.stderr
    assert list(folder.iterdir()) == []
