"""The command line: user errors are one line on stderr and exit status 2."""

from __future__ import annotations

import pytest

from stiction import cli


def test_help_lists_commands(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    assert "bench" in capsys.readouterr().out


def test_unknown_benchmark_is_a_user_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["bench", "no-such-bench"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("stiction: error:") and "Traceback" not in err


def test_replay_factories_survive_their_modules_being_imported() -> None:
    """The drivers' replay() factories (drivers/source.py) must not be shadowed by a
    submodule of the same name once the implementation module has been loaded."""
    import importlib

    for package in ("stiction.drivers.hid", "stiction.drivers.evdev"):
        pkg = importlib.import_module(package)
        importlib.import_module(f"{package}.playback")
        assert callable(pkg.replay) and type(pkg.replay).__name__ == "function"
