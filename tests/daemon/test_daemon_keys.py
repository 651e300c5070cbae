"""`stiction keys` writes the secret half private; daemon and clients refuse one others can read."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.clients.curve import CurveKeyError, CurveKeys


def _keys(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "stiction", "keys", *args],
        capture_output=True,
        text=True,
        timeout=60,
    )


def _mode(p: Path) -> int:
    return stat.S_IMODE(p.stat().st_mode)


def test_keys_are_written_private_and_not_overwritten(tmp_path: Path) -> None:
    os.umask(0o022)  # the usual umask, which made the secret 0644 before
    done = _keys(str(tmp_path / "k"), "daemon")
    assert done.returncode == 0, done.stderr
    public, secret = tmp_path / "k" / "daemon.key", tmp_path / "k" / "daemon.key_secret"
    assert _mode(secret) == 0o600 and _mode(public) == 0o644
    assert [p.name for p in (tmp_path / "k").iterdir()] != []  # no temporary folder left
    assert sorted(p.name for p in (tmp_path / "k").iterdir()) == ["daemon.key", "daemon.key_secret"]
    before = secret.read_bytes()
    again = _keys(str(tmp_path / "k"), "daemon")
    assert again.returncode == 2 and "--force" in again.stderr
    assert secret.read_bytes() == before
    assert _keys(str(tmp_path / "k"), "daemon", "--force").returncode == 0
    assert secret.read_bytes() != before and _mode(secret) == 0o600


def test_the_daemon_refuses_a_secret_key_others_can_read(tmp_path: Path) -> None:
    assert _keys(str(tmp_path), "daemon").returncode == 0
    secret = tmp_path / "daemon.key_secret"
    os.chmod(secret, 0o644)
    (tmp_path / "clients").mkdir()
    done = subprocess.run(
        [
            sys.executable, "-m", "stiction.daemon.main", "--device", "synthetic:demo",
            "--pub", f"ipc://{tmp_path}/pub", "--control", f"ipc://{tmp_path}/ctl",
            "--curve-secret-key", str(secret), "--curve-authorized", str(tmp_path / "clients"),
            "--curve-required", "--seconds", "0.1",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )  # fmt: skip
    assert done.returncode == 2
    assert f"chmod 600 {secret}" in done.stderr and "Traceback" not in done.stderr


def test_a_client_refuses_a_secret_key_others_can_read(tmp_path: Path) -> None:
    assert _keys(str(tmp_path), "daemon").returncode == 0
    assert _keys(str(tmp_path), "client").returncode == 0
    secret = tmp_path / "client.key_secret"
    CurveKeys.from_files(tmp_path / "daemon.key", secret)  # private: accepted
    os.chmod(secret, 0o640)
    with pytest.raises(CurveKeyError, match="chmod 600"):
        CurveKeys.from_files(tmp_path / "daemon.key", secret)


@pytest.mark.parametrize("name", ["", ".hidden", "../escape", "a/b", "x" * 65, "new\nline"])
def test_a_key_name_that_is_not_a_plain_file_name_is_refused(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from stiction import cli

    assert cli.main(["keys", str(tmp_path / "k"), name]) == 2
    err = capsys.readouterr().err
    assert "key name" in err and "letters, digits" in err and err.count("\n") == 1
    assert not (tmp_path / "k").exists() or not list((tmp_path / "k").iterdir())


def test_keys_into_a_file_says_it_is_not_a_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from stiction import cli

    (tmp_path / "file").write_text("x")
    assert cli.main(["keys", str(tmp_path / "file"), "daemon"]) == 2
    assert "is not a folder" in capsys.readouterr().err
