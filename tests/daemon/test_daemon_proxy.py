"""`stiction proxy` forwards a daemon's frames; `stiction keys` makes usable key pairs."""

from __future__ import annotations

import threading
from pathlib import Path

import msgpack
import pytest
import zmq
import zmq.auth
from daemon_support import ListSource, Runner, make_daemon, stroke

from stiction import cli
from stiction.daemon.proxy import run_proxy
from stiction.daemon.security import CurveConfig, SecurityError


def test_proxy_forwards_frames_and_subscriptions(tmp_path: Path) -> None:
    gate = threading.Event()
    d = make_daemon(
        (f"ipc://{tmp_path}/pub", f"ipc://{tmp_path}/ctl"),
        {"pen": ListSource(stroke(n=20), gate=gate)},
        keepalive=0,  # a frame every tick, so consecutive ticks show nothing was lost
    )
    backend = f"ipc://{tmp_path}/proxy"
    pctx = zmq.Context()
    proxy = threading.Thread(
        target=run_proxy, args=(pctx, [f"ipc://{tmp_path}/pub"], backend, CurveConfig())
    )
    proxy.start()
    ctx = zmq.Context()
    sub = ctx.socket(zmq.SUB)
    sub.linger = 0
    sub.connect(backend)
    sub.setsockopt(zmq.SUBSCRIBE, b"frame.")
    try:
        with Runner(d):
            ticks = []
            while len(ticks) < 10:
                assert sub.poll(5000), "nothing came through the proxy"
                topic, payload = sub.recv_multipart()
                assert topic == b"frame.test-pen"  # the scene topic was not subscribed
                ticks.append(msgpack.unpackb(payload)["tick"])
            assert ticks == list(range(ticks[0], ticks[0] + 10))
            gate.set()
    finally:
        sub.close()
        ctx.term()
        pctx.term()  # ends zmq.proxy
        proxy.join(10)
    assert not proxy.is_alive()


def test_proxy_refuses_a_clear_text_network_bind() -> None:
    ctx = zmq.Context()
    try:
        with pytest.raises(SecurityError, match="needs CURVE keys"):
            run_proxy(ctx, ["tcp://127.0.0.1:5999"], "tcp://0.0.0.0:*", CurveConfig())
    finally:
        ctx.term()


def test_keys_command_writes_a_loadable_pair(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main(["keys", str(tmp_path / "k"), "daemon"]) == 0
    public, secret = zmq.auth.load_certificate(str(tmp_path / "k" / "daemon.key_secret"))
    assert len(public) == 40 and secret is not None and len(secret) == 40
    assert public.decode() in capsys.readouterr().out
