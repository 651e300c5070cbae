"""CURVE with real sockets on 127.0.0.1: authorised peers only, never a clear-text bind."""

from __future__ import annotations

import logging
import os
import threading
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zmq
import zmq.auth
from daemon_support import ListSource, Runner, make_daemon, stroke

from stiction import protocol
from stiction.daemon.security import ZAP_DOMAIN, CurveConfig, SecurityError, is_local_endpoint


def _keypair(directory, name):  # type: ignore[no-untyped-def]
    """The project's own writer: the secret half is private (0600), as the daemon requires."""
    from stiction.keyfiles import write_keypair

    public, secret = write_keypair(Path(directory), name, force=True)
    return str(public), str(secret)


@pytest.mark.parametrize(
    ("endpoint", "local"),
    [
        ("ipc:///tmp/x", True),
        ("inproc://x", True),
        ("tcp://127.0.0.1:5556", True),
        ("tcp://127.9.9.9:1", True),
        ("tcp://[::1]:5556", True),
        ("tcp://localhost:5556", True),
        ("tcp://0.0.0.0:5556", False),
        ("tcp://*:5556", False),
        ("tcp://192.168.1.5:5556", False),
        ("tcp://eth0:5556", False),
        ("udp://127.0.0.1:1", False),
    ],
)
def test_loopback_detection(endpoint: str, local: bool) -> None:
    assert is_local_endpoint(endpoint) is local


@pytest.mark.parametrize("pub", ["tcp://0.0.0.0:*", "tcp://*:*"])
def test_network_bind_without_keys_is_refused(pub: str, tmp_path: Path) -> None:
    with pytest.raises(SecurityError, match="needs CURVE keys"):
        make_daemon((pub, f"ipc://{tmp_path}/c"), {"pen": ListSource(stroke())})


@pytest.fixture
def keys(tmp_path: Path) -> dict[str, Path]:
    auth = tmp_path / "authorized"
    auth.mkdir()
    (tmp_path / "private").mkdir()
    out = {}
    for name in ("server", "client", "intruder"):
        public, secret = _keypair(tmp_path / "private", name)
        out[name] = Path(secret)
        out[name + ".pub"] = Path(public)
    # Only the client's public key is authorised.
    (auth / "client.key").write_bytes(out["client.pub"].read_bytes())
    out["authorized"] = auth
    return out


def _client(ctx: zmq.Context[Any], kind: int, keys: dict[str, Path], who: str | None) -> Any:
    s = ctx.socket(kind)
    s.linger = 0
    if who is not None:
        public, secret = zmq.auth.load_certificate(str(keys[who]))
        s.curve_publickey = public
        s.curve_secretkey = secret
        s.curve_serverkey = zmq.auth.load_certificate(str(keys["server.pub"]))[0]
    return s


def test_only_authorised_peers_are_accepted(keys: dict[str, Path]) -> None:
    gate = threading.Event()
    curve = CurveConfig(keys["server"], keys["authorized"], required=True)
    d = make_daemon(
        ("tcp://127.0.0.1:*", "tcp://127.0.0.1:*"),
        {"pen": ListSource(stroke(n=20), gate=gate)},
        curve=curve,
        keepalive=0,  # a frame every tick, pen down or not: 20 come quickly
    )
    assert d.publisher is not None and d.control is not None
    pub, ctl = d.publisher.endpoint, d.control.endpoint
    ctx = zmq.Context()
    subs = {
        who: _client(ctx, zmq.SUB, keys, None if who == "plain" else who)
        for who in ("client", "intruder", "plain")
    }
    for s in subs.values():
        s.setsockopt(zmq.SUBSCRIBE, b"")
        s.connect(pub)
    try:
        with Runner(d):
            got = 0
            while got < 20:
                assert subs["client"].poll(5000), "the authorised client got nothing"
                _, payload = subs["client"].recv_multipart()
                got += msgpack.unpackb(payload)["kind"] == "frame"
            # 20 frames reached the client; the others have had the same chance.
            assert subs["intruder"].poll(300) == 0
            assert subs["plain"].poll(0) == 0

            req = _client(ctx, zmq.REQ, keys, "client")
            req.connect(ctl)
            req.send(protocol.make_request("ping"))
            assert req.poll(5000) and msgpack.unpackb(req.recv())["ok"]
            bad = _client(ctx, zmq.REQ, keys, "intruder")
            bad.connect(ctl)
            bad.send(protocol.make_request("set_params", mu_s=0.0))
            assert bad.poll(300) == 0  # never read, never answered
            req.send(protocol.make_request("stats"))
            assert req.poll(5000)
            stats = msgpack.unpackb(req.recv())["stats"]
            assert stats["control_requests"] == 2  # the intruder's request never arrived
            req.close()
            bad.close()
            gate.set()
    finally:
        for s in subs.values():
            s.close()
        ctx.term()


def test_control_client_with_a_refused_key_returns_promptly(keys: dict[str, Path]) -> None:
    """A refused CURVE handshake leaves a REQ socket with no peer: the project's
    control client bounds the send as well as the reply and says what failed."""
    from stiction.clients.control import ControlUnavailable, request
    from stiction.clients.curve import CurveKeys

    curve = CurveConfig(keys["server"], keys["authorized"], required=True)
    d = make_daemon(
        ("tcp://127.0.0.1:*", "tcp://127.0.0.1:*"),
        {"pen": ListSource(stroke(n=5), gate=threading.Event())},
        curve=curve,
    )
    assert d.control is not None
    ctl = d.control.endpoint
    wrong = CurveKeys.from_files(keys["server.pub"], keys["intruder"])
    right = CurveKeys.from_files(keys["server.pub"], keys["client"])
    outcome: list[BaseException | dict[str, Any]] = []

    def ask() -> None:
        for _ in range(3):  # the same client, asking again after a refusal
            try:
                outcome.append(request(ctl, "ping", timeout=0.3, curve=wrong))
            except BaseException as exc:
                outcome.append(exc)

    with Runner(d):
        t = threading.Thread(target=ask, daemon=True)
        t.start()
        t.join(30)
        assert not t.is_alive(), "the control client hung on a refused handshake"
        assert request(ctl, "ping", timeout=5, curve=right)["ok"]
    assert len(outcome) == 3
    for exc in outcome:
        assert isinstance(exc, ControlUnavailable), exc
        assert "within 0.3 s" in str(exc)


def _damage(path: Path) -> None:
    """Keep the file's shape but cut its secret key short (a bad copy-paste)."""
    text = path.read_text()
    start = text.index('secret-key = "') + len('secret-key = "')
    path.write_text(text[:start] + "short" + text[text.index('"', start) :])


def test_a_damaged_or_fifo_key_in_the_authorised_folder_locks_nobody_out(
    keys: dict[str, Path], caplog: pytest.LogCaptureFixture
) -> None:
    from stiction.daemon.security import AuthorizedKeys

    folder = keys["authorized"]
    (folder / "garbage.key").write_bytes(b"\x00\xff not a certificate")
    os.mkfifo(folder / "fifo.key")  # zmq.auth opened it and blocked, even SIGTERM
    authorized = AuthorizedKeys(folder)
    with caplog.at_level(logging.WARNING, "stiction.daemon.security"):
        assert authorized.reload() == 1
    client_public = zmq.auth.load_certificate(str(keys["client.pub"]))[0]
    assert authorized.callback(ZAP_DOMAIN, client_public)
    assert not authorized.callback(ZAP_DOMAIN, b"x" * 40)
    skipped = " ".join(r.getMessage() for r in caplog.records)
    assert "garbage.key" in skipped and "fifo.key" in skipped


@pytest.mark.parametrize("problem", ["garbage", "fifo", "damaged", "alone"])
def test_a_given_key_that_cannot_be_used_stops_the_start_even_on_loopback(
    keys: dict[str, Path], tmp_path: Path, problem: str
) -> None:
    """Keys were read only when an endpoint needed them, so a broken one passed unseen."""
    secret: Path = keys["server"]
    authorized: Path | None = keys["authorized"]
    if problem == "garbage":
        secret = tmp_path / "garbage.key_secret"
        secret.write_bytes(b"\x00\xff")
    elif problem == "fifo":
        secret = tmp_path / "fifo.key_secret"
        os.mkfifo(secret)
    elif problem == "damaged":
        _damage(secret)
    else:
        authorized = None
    curve = CurveConfig(secret, authorized)
    with pytest.raises(SecurityError) as caught:
        make_daemon((f"ipc://{tmp_path}/p", f"ipc://{tmp_path}/c"), {}, curve=curve)
    assert "\n" not in str(caught.value)


def test_a_client_with_a_damaged_key_is_one_error_not_a_zmq_traceback(
    keys: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    from stiction import cli

    _damage(keys["client"])
    argv = ["listen", "ipc:///nonexistent/p", "--no-control", "--seconds", "0.1"]
    argv += ["--curve-server-key", str(keys["server.pub"])]
    argv += ["--curve-client-key", str(keys["client"])]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "not 40 Z85 characters" in err and "Traceback" not in err
