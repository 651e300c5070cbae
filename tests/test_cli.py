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
