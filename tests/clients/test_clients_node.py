"""The Node.js example client against the real daemon: it must decode exactly
what the Python Subscriber decodes. This is how we know docs/protocol.md is
complete enough to write a client from it alone."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from stiction.clients import Frame, Subscriber

pytest_plugins = ["clients_fixtures"]

pytestmark = [pytest.mark.node, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
NODE_DIR = REPO / "clients" / "examples" / "node"
STICTIOND = Path(sys.executable).with_name("stictiond")
NODE_ARGS = ("--count", "150", "--json")


@pytest.fixture
def node() -> str:
    exe = shutil.which("node")
    if exe is None:
        pytest.fail("node not found: install nodejs (make sysdeps)")
    if not (NODE_DIR / "node_modules" / "zeromq").is_dir():
        pytest.fail(f"npm packages missing: run `make node-deps` (npm ci in {NODE_DIR})")
    return exe


def start_daemon(short_dir: Path, seconds: float) -> tuple[subprocess.Popen[bytes], str, str]:
    pub, ctl = f"ipc://{short_dir}/pub", f"ipc://{short_dir}/ctl"
    proc = subprocess.Popen(
        [
            *(str(STICTIOND), "--clock", "real", "--seconds", str(seconds), "--no-hotplug"),
            *("--device", "synthetic:demo", "--pub", pub, "--control", ctl),
        ],
        stdout=subprocess.DEVNULL,
        stderr=(short_dir / "stictiond.log").open("wb"),  # a file: a full pipe would stall it
    )
    return proc, pub, ctl


def test_node_client_decodes_what_python_decodes(node: str, short_dir: Path) -> None:
    daemon, pub, ctl = start_daemon(short_dir, 8)
    try:
        with Subscriber(pub) as sub:
            first = sub.recv(timeout=30)  # the daemon is up and publishing
            assert isinstance(first, Frame), (short_dir / "stictiond.log").read_text()
            # Output to a file, not a pipe: 150 JSON frames overflow a pipe's
            # buffer and Node would block writing while we wait for it.
            out_path, err_path = short_dir / "node.out", short_dir / "node.err"
            with out_path.open("wb") as out_f, err_path.open("wb") as err_f:
                client = subprocess.Popen(
                    [node, str(NODE_DIR / "subscribe.mjs"), pub, *("--control", ctl), *NODE_ARGS],
                    stdout=out_f,
                    stderr=err_f,
                )
            python: dict[int, dict[str, object]] = {first.tick: dict(first.wire)}
            # Keep reading while Node runs, then until Python has every tick Node printed.
            deadline = time.monotonic() + 60
            while client.poll() is None and time.monotonic() < deadline:
                msg = sub.recv(timeout=0.05)
                if isinstance(msg, Frame):
                    python[msg.tick] = dict(msg.wire)
            client.wait(10)
            assert client.returncode == 0, err_path.read_text()
            from_node = [json.loads(line) for line in out_path.read_text().splitlines()]
            assert len(from_node) == 150
            want = max(f["tick"] for f in from_node)
            deadline = time.monotonic() + 30
            while max(python) < want and time.monotonic() < deadline:
                msg = sub.recv(timeout=1)
                if isinstance(msg, Frame):
                    python[msg.tick] = dict(msg.wire)
    finally:
        daemon.terminate()
        daemon.wait(30)
    ticks = [f["tick"] for f in from_node]
    # Node followed the clone pattern: consecutive ticks, nothing twice.
    assert ticks == list(range(ticks[0], ticks[0] + 150))
    for f in from_node:
        assert f == python[f["tick"]], f"tick {f['tick']} differs"
    # The comparison covered real content, not only empty frames.
    assert any(c["phase"] in ("stick", "slip") for f in from_node for c in f["contacts"])


def test_node_client_refuses_a_newer_schema(node: str, daemon: object) -> None:
    from clients_support import FakeDaemon, make_frame

    assert isinstance(daemon, FakeDaemon)
    client = subprocess.Popen(
        [node, str(NODE_DIR / "subscribe.mjs"), daemon.pub_endpoint, "--count", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    daemon.wait_subscribers()
    daemon.send_raw(b"frame.pen", b"\xc1")
    daemon.send({**make_frame(0), "v": 2})
    _out, err = client.communicate(timeout=30)
    assert client.returncode == 2
    assert "skipped a bad message" in err.decode()
    assert "schema version 2, newer than this client's 1" in err.decode()
