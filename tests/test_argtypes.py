"""Every flag is checked by its own type, and the error names the flag (exit 2, usage line)."""

from __future__ import annotations

import pytest

from stiction import cli
from stiction.daemon import main as daemon_main


@pytest.mark.parametrize(
    ("argv", "flag", "words"),
    [
        (["--pub", "tcp://127.0.0.1:99999"], "--pub", "out of range"),
        (["--pub", "garbage"], "--pub", "not a ZeroMQ endpoint"),
        (["--control", "tcp://127.0.0.1:port"], "--control", "not a number"),
        (["--seconds", "-1"], "--seconds", "positive"),
        (["--seconds", "0"], "--seconds", "positive"),
        (["--rate", "nan"], "--rate", "finite"),
        (["--hwm", "-5"], "--hwm", "at least 1"),
        (["--hwm", "0"], "--hwm", "at least 1"),
        (["--keepalive", "-1"], "--keepalive", "negative"),
        (["--realtime", "100"], "--realtime", "0 to 99"),
        (["--spin-ms", "-0.1"], "--spin-ms", "negative"),
        # Each of these once reached ZeroMQ and raised OverflowError (a traceback; --hwm
        # also left the daemon hung with its loop thread dead).
        (["--wait-timeout", "1e300"], "--wait-timeout", "at most 1e+09 seconds"),
        (["--seconds", "1e10"], "--seconds", "at most 1e+09 seconds"),
        (["--keepalive", "1e300"], "--keepalive", "at most 1e+09 seconds"),
        (["--hwm", "99999999999999999999"], "--hwm", "at most 2147483647"),
    ],
)
def test_stictiond_flags(
    argv: list[str], flag: str, words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_:
        daemon_main.build_parser().parse_args(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: stictiond")
    assert f"error: argument {flag}: " in err and words in err


@pytest.mark.parametrize(
    ("argv", "flag", "words"),
    [
        (["listen", "tcp://127.0.0.1:99999"], "endpoint", "out of range"),
        (["listen", "--count", "0"], "--count", "at least 1"),
        (["listen", "--seconds", "-2"], "--seconds", "positive"),
        (["record", "--out", "x.npz", "--count", "-1"], "--count", "at least 1"),
        (["record", "garbage", "--out", "x.npz"], "endpoint", "not a ZeroMQ endpoint"),
        (["replay", "f.npz", "--pub", "tcp://*:70000"], "--pub", "out of range"),
        (["replay", "f.npz", "--loop", "-1"], "--loop", "negative"),
        (["replay", "f.npz", "--speed", "0"], "--speed", "positive"),
        (["web", "--pub", "nothing"], "--pub", "not a ZeroMQ endpoint"),
        (["web", "--port", "65536"], "--port", "0-65535"),
        (["proxy", "--frontend", "tcp://h:0", "--backend", "ipc://x"], "--frontend", "range"),
        (["listen", "--seconds", "1e300"], "--seconds", "at most"),  # was OverflowError in poll
        (["record", "--out", "x.npz", "--idle", "1e300"], "--idle", "at most"),
        (["replay", "f.npz", "--wait", "1e300"], "--wait", "at most"),
        (["replay", "f.npz", "--hold", "1e300"], "--hold", "at most"),
        (["replay", "f.npz", "--speed", "1e-300"], "--speed", "from 1e-06 to 1e+06"),
        (["web", "--seconds", "1e300"], "--seconds", "at most"),
        (["demo", "--seconds", "1e300"], "--seconds", "at most"),
        (["demo", "--port", "65536"], "--port", "0-65535"),
        # experiment run passed these to zmq unchecked: a ZMQError traceback.
        (
            ["experiment", "run", "s", "--participant", "p", "--control", "foo"],
            "--control",
            "not a",
        ),
        (["experiment", "run", "s", "--participant", "p", "--pub", "foo"], "--pub", "not a"),
        (["experiment", "run", "s", "--participant", "p", "--port", "99999"], "--port", "0-65535"),
        # plain int/float flags took NaN, negative counts and islice(-1) (a ValueError).
        (["hid", "record", "/dev/hidraw0", "--seconds", "nan"], "--seconds", "finite"),
        (["hid", "record", "/dev/hidraw0", "--count", "-1"], "--count", "negative"),
        (["hid", "read", "/dev/hidraw0", "--count", "-1"], "--count", "negative"),
        (["evdev", "read", "/dev/input/event0", "--frames", "-1"], "--frames", "at least 1"),
        (["evdev", "record", "/dev/input/event0", "o.evemu", "--frames", "0"], "--frames", "at"),
        (["evdev", "decode", "r.evemu", "--index", "-1"], "--index", "negative"),
    ],
)
def test_stiction_flags(
    argv: list[str], flag: str, words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_:
        cli.build_parser().parse_args(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: stiction")
    assert f"error: argument {flag}: " in err and words in err


@pytest.mark.parametrize(
    "good",
    [
        "tcp://127.0.0.1:5555",
        "tcp://*:*",
        "tcp://[::1]:80",
        "tcp://[fe80::1%eth0]:80",
        "tcp://eth0:5556",
        "tcp://tablet-pc:5556",
        "ipc:///tmp/x",
        "inproc://a",
    ],
)
def test_good_endpoints_pass(good: str) -> None:
    assert daemon_main.build_parser().parse_args(["--pub", good]).pub == good


def test_config_endpoint_names_its_key(tmp_path: pytest.TempPathFactory) -> None:
    from pathlib import Path

    from stiction.daemon.config import load_options
    from stiction.errors import StictionError

    path = Path(str(tmp_path)) / "d.toml"
    path.write_text('[daemon]\npub = "tcp://127.0.0.1:99999"\n')
    with pytest.raises(StictionError, match=r"daemon\.pub.*out of range"):
        load_options(path)


@pytest.mark.parametrize(
    ("bad", "words"),
    [
        # libzmq took these and retried the connect forever: `listen` just waited
        ("tcp://[::1:5556", "not an IPv6 address in brackets"),
        ("tcp://1.2.3.4.5:1", "not an IPv4 address"),
        ("tcp://256.0.0.1:1", "not an IPv4 address"),
        ("tcp://::1:5556", "in brackets"),
        ("tcp://my host:5556", "not a host name"),
    ],
)
def test_malformed_hosts_are_refused(
    bad: str, words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        cli.build_parser().parse_args(["listen", bad])
    assert words in capsys.readouterr().err


@pytest.mark.parametrize(
    ("given", "served"),
    [("[::1]", "::1"), ("::1", "::1"), ("127.0.0.1", "127.0.0.1"), ("localhost", "localhost")],
)
def test_web_host_takes_ipv6_with_or_without_brackets(given: str, served: str) -> None:
    """`stiction web --host [::1]` failed with "Name or service not known": the
    brackets of the URL form reached getaddrinfo."""
    from stiction.argtypes import http_host

    assert http_host(given) == served


@pytest.mark.parametrize(
    ("given", "message"),
    [
        ("[::1", "not an IPv6 address"),
        ("1.2.3.4.5", "not a host name or an IPv4 or IPv6 address"),
        ("bad host", "not a host name"),
        ("*", "ZeroMQ's wildcard"),
    ],
)
def test_web_host_refuses_what_cannot_be_served(
    given: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main(["web", "--host", given, "--no-control", "--seconds", "0.1"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
