"""Silence explained: `listen` (and the web bridge) tell no daemon from no device yet."""

from __future__ import annotations

from pathlib import Path

import pytest
from clients_support import WAITED_FOR

from stiction import cli
from stiction.clients.control import ControlUnavailable
from stiction.clients.diagnose import explain
from stiction.errors import ProtocolError

pytest_plugins = ["clients_fixtures"]

PUB, CTL = "ipc:///tmp/x-pub", "ipc:///tmp/x-ctl"


def dev(spec: str, state: str) -> dict[str, object]:
    return {"name": spec, "spec": spec, "state": state}


@pytest.mark.parametrize(
    ("reply", "error", "kind", "words"),
    [
        (None, ControlUnavailable("no reply"), "no-daemon", "is stictiond running?"),
        (None, ProtocolError("unknown op"), "unknown", "refused the devices request"),
        ({"devices": []}, None, "no-device", "reads no device"),
        ({"devices": [dev("256c:006d", "waiting")]}, None, "no-device", "256c:006d (waiting)"),
        ({"devices": [dev("/dev/input/event5", "absent")]}, None, "no-device", "(absent)"),
        ({"devices": [dev("replay:a.npz", "ended")]}, None, "ended", "have ended"),
        ({"devices": [dev("synthetic:demo", "open")]}, None, "elsewhere", "--pub endpoint"),
    ],
)
def test_each_silence_has_its_own_words(
    reply: dict[str, object] | None, error: Exception | None, kind: str, words: str
) -> None:
    got_kind, message = explain(PUB, CTL, reply, error)  # type: ignore[arg-type]
    assert got_kind == kind
    assert words in message


def test_a_device_filter_the_daemon_cannot_satisfy_is_named() -> None:
    """listen --device typo said 'nothing arrives on PUB: is that its --pub endpoint?'."""
    reply = {"devices": [dev("synthetic-demo", "open")]}
    kind, message = explain(PUB, CTL, reply, None, ["nosuch"])
    assert kind == "elsewhere" and "has no device 'nosuch'" in message
    assert "--device takes one of: synthetic-demo" in message and "--pub" not in message
    kind, message = explain(PUB, CTL, reply, None, ["synthetic-demo"])
    assert "--pub endpoint" in message  # the filter is fine: back to the endpoint


def test_without_a_control_endpoint_it_can_only_ask() -> None:
    kind, message = explain(PUB, None, None, None)
    assert kind == "unknown" and "is stictiond running?" in message


@pytest.mark.slow
def test_listen_says_the_daemon_is_up_but_has_no_device_yet(
    stictiond_without_device: tuple[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    pub, ctl = stictiond_without_device
    assert cli.main(["listen", pub, "--control", ctl, "--seconds", "0.5"]) == 1
    err = capsys.readouterr().err
    assert f"has no device yet: waiting for {WAITED_FOR} (waiting)" in err, err
    assert "is stictiond running?" not in err


def test_listen_says_no_daemon_answers(short_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pub, ctl = f"ipc://{short_dir}/pub", f"ipc://{short_dir}/ctl"
    assert cli.main(["listen", pub, "--control", ctl, "--seconds", "0.1"]) == 1
    err = capsys.readouterr().err
    assert f"no daemon answers at {ctl}: is stictiond running?" in err, err
