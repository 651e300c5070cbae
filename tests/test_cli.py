"""The command line: user errors are one line on stderr and exit status 2."""

from __future__ import annotations

import json
import subprocess
import sys

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


# Packages `stiction --help` must not load: building the parser imports every
# command module, and these cost tens of milliseconds each (numpy alone ~0.1 s)
# or touch hardware libraries. msgpack is allowed: clients/cli.py takes the
# default endpoints from stiction.protocol, which imports msgpack at module level.
HEAVY = ("numpy", "numba", "matplotlib", "zmq", "msgpack", "evdev", "hid", "usb", "pyudev")
HEAVY += ("aiohttp", "playwright", "asyncio")
ALLOWED = {"msgpack"}

_PARSER_IMPORTS = """
import contextlib, io, json, sys
from stiction import cli

parser = cli.build_parser()
commands = sorted(next(a for a in parser._actions if a.dest == "command").choices)
codes = {}
for argv in [[c, "--help"] for c in commands] + [["simulate"], ["record", "--count", "x"]]:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            cli.main(argv)
        except SystemExit as exc:
            codes[" ".join(argv)] = exc.code
heavy = sorted(m for m in sys.argv[1:] if m in sys.modules)
print(json.dumps({"commands": commands, "codes": codes, "heavy": heavy}))
"""


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=60, check=False
    )


def test_parser_and_argument_errors_import_nothing_heavy() -> None:
    """A fresh interpreter: build the parser, ask every command for --help and make
    two argument errors; none of that may import numpy, pyzmq, asyncio, ..."""
    proc = _run("-c", _PARSER_IMPORTS, *HEAVY)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert len(result["commands"]) > 10
    assert set(result["codes"].values()) == {0, 2}, result["codes"]
    assert set(result["heavy"]) <= ALLOWED, f"imported while building the parser: {result}"


def test_help_in_a_fresh_process_lists_every_command() -> None:
    proc = _run("-m", "stiction", "--help")
    assert proc.returncode == 0, proc.stderr
    # "    name   help" lines; wrapped help continues further indented
    lines = proc.stdout.splitlines()
    listed = {ln.split()[0] for ln in lines if ln[:4] == "    " and ln[4:5].strip()}
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    assert set(commands) <= listed, f"missing from --help: {set(commands) - listed}"


@pytest.mark.parametrize("package", ["stiction.sim", "stiction.clients"])
def test_lazy_package_exports(package: str) -> None:
    """The packages' names load on first use, and are the objects their modules define."""
    import importlib

    pkg = importlib.import_module(package)
    assert set(pkg._SOURCES) == set(pkg.__all__)
    for name in pkg.__all__:
        assert getattr(pkg, name) is getattr(importlib.import_module(pkg._SOURCES[name]), name)
        assert name in dir(pkg)
    with pytest.raises(AttributeError, match="has no attribute 'NoSuchName'"):
        _ = pkg.NoSuchName


def test_submodules_still_import_from_the_lazy_packages() -> None:
    from stiction.clients import control
    from stiction.sim import kernels

    assert control.__name__ == "stiction.clients.control"
    assert kernels.__name__ == "stiction.sim.kernels"


def test_verbose_is_accepted_after_the_subcommand() -> None:
    parser = cli.build_parser()
    assert parser.parse_args(["doctor", "-v"]).verbose == 1
    assert parser.parse_args(["-v", "doctor"]).verbose == 1
    assert parser.parse_args(["devices", "-vv"]).verbose == 2
    assert parser.parse_args(["devices"]).verbose == 0


def test_devices_json_is_one_array_even_when_empty(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from stiction.drivers import cli as drivers_cli

    monkeypatch.setattr(drivers_cli, "discover_all", lambda: [])
    assert cli.main(["devices", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == []
