"""The systemd user unit: it parses, installs into $XDG_CONFIG_HOME, and its command runs."""

from __future__ import annotations

import configparser
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.daemon.config import load_options
from stiction.daemon.main import build_parser
from stiction.setup import service

VENV_BIN = Path(sys.executable).parent


def _install(xdg: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, XDG_CONFIG_HOME=str(xdg))
    return subprocess.run(
        [sys.executable, "-m", "stiction", "service", "install", *args],
        capture_output=True,
        text=True,
        env=env,
        check=False,
        timeout=60,
    )


def _unit(text: str) -> configparser.ConfigParser:
    parser = configparser.ConfigParser(strict=True, interpolation=None, comment_prefixes=("#",))
    parser.optionxform = str  # type: ignore[assignment,method-assign]
    parser.read_string(text)
    return parser


def test_shipped_unit_parses_and_runs_stictiond_with_the_xdg_config() -> None:
    unit = _unit(service.shipped_unit())
    assert set(unit.sections()) == {"Unit", "Service", "Install"}
    assert unit["Install"]["WantedBy"] == "default.target"
    argv = shlex.split(unit["Service"]["ExecStart"])
    assert argv[0] == "stictiond"
    args = build_parser().parse_args(argv[1:])  # the daemon's real flags
    assert str(args.config) == "%E/stiction/stictiond.toml"
    assert unit["Service"]["RestartPreventExitStatus"] == "2"


def test_install_into_xdg_config_home(tmp_path: Path) -> None:
    xdg = tmp_path / "xdg"
    proc = _install(xdg)
    assert proc.returncode == 0, proc.stderr
    unit_file = xdg / "systemd" / "user" / "stictiond.service"
    config = xdg / "stiction" / "stictiond.toml"
    assert unit_file.is_file() and config.is_file()
    assert (
        "systemctl --user daemon-reload && systemctl --user enable --now stictiond" in proc.stdout
    )
    assert "journalctl --user -u stictiond -f" in proc.stdout
    argv = shlex.split(_unit(unit_file.read_text())["Service"]["ExecStart"])
    exe = Path(argv[0])
    assert exe.is_absolute() and os.access(exe, os.X_OK)
    assert exe == VENV_BIN / "stictiond"
    assert argv[1:] == ["--config", "%E/stiction/stictiond.toml"]
    assert load_options(config).devices == []  # the starter config is valid and empty

    config.write_text("# mine\n")
    again = _install(xdg)
    assert again.returncode == 0
    assert "already up to date" in again.stdout and "kept as it is" in again.stdout
    assert config.read_text() == "# mine\n"


def test_dry_run_writes_nothing(tmp_path: Path) -> None:
    xdg = tmp_path / "xdg"
    proc = _install(xdg, "--dry-run")
    assert proc.returncode == 0, proc.stderr
    assert not xdg.exists()
    assert f"would write {xdg}/systemd/user/stictiond.service" in proc.stdout
    assert "[Service]" in proc.stdout


def test_unset_xdg_config_home_means_dot_config(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    assert service.unit_path() == Path.home() / ".config/systemd/user/stictiond.service"
    monkeypatch.setenv("XDG_CONFIG_HOME", "relative/not/allowed")
    assert service.config_path() == Path.home() / ".config/stiction/stictiond.toml"


def test_the_installed_command_starts_the_daemon_with_the_starter_config(tmp_path: Path) -> None:
    """ExecStart with %E expanded, plus flags for a short offline run, exits cleanly."""
    xdg = tmp_path / "xdg"
    assert _install(xdg).returncode == 0
    argv = shlex.split(
        _unit((xdg / "systemd/user/stictiond.service").read_text())["Service"]["ExecStart"]
    )
    argv = [a.replace("%E", str(xdg)) for a in argv]
    sock = tmp_path / "s"
    proc = subprocess.run(
        [
            *argv,
            "--device",
            "synthetic:demo",
            "--clock",
            "virtual",
            "--seconds",
            "0.2",
            "--pub",
            f"ipc://{sock}-pub",
            "--control",
            f"ipc://{sock}-ctl",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="no systemd-analyze")
def test_systemd_analyze_verify(tmp_path: Path) -> None:
    """systemd's own parser accepts the installed unit without a single warning."""
    xdg = tmp_path / "xdg"
    assert _install(xdg).returncode == 0
    unit_file = xdg / "systemd" / "user" / "stictiond.service"

    def verify(path: Path) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            ["systemd-analyze", "verify", str(path)],
            capture_output=True,
            text=True,
            check=False,
            timeout=60,
        )

    good = verify(unit_file)
    assert good.returncode == 0 and good.stderr == "", good.stderr
    # the check can fail: systemd-analyze warns (exit 0) about a bad value
    broken = tmp_path / "broken" / "stictiond.service"
    broken.parent.mkdir()
    broken.write_text(unit_file.read_text().replace("Restart=on-failure", "Restart=bogus"))
    assert "bogus" in verify(broken).stderr


def test_a_customised_unit_is_replaced_only_with_force(tmp_path: Path) -> None:
    xdg = tmp_path / "xdg"
    assert _install(xdg).returncode == 0
    unit_file = xdg / "systemd" / "user" / "stictiond.service"
    mine = unit_file.read_text().replace("[Service]", "[Service]\nNice=-5")
    unit_file.write_text(mine)
    refused = _install(xdg)
    assert refused.returncode == 2 and "--force" in refused.stderr
    assert "Traceback" not in refused.stderr and unit_file.read_text() == mine
    assert _install(xdg, "--force").returncode == 0
    assert "Nice=-5" not in unit_file.read_text()
