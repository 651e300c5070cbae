"""synthetic:stdin: a pen steered line by line, through the real HID path and the real daemon."""

from __future__ import annotations

import io
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
import zmq

from stiction import protocol
from stiction.drivers.fake.feed import format_state, read_states
from stiction.drivers.fake.strokes import PenState
from stiction.errors import DeviceError

DAEMON = [
    sys.executable,
    "-c",
    "import sys; from stiction.daemon.main import main; sys.exit(main())",
]


def test_lines_round_trip() -> None:
    s = PenState(0.125, 0.05, 0.04, True, True, 0.4)
    (back,) = read_states(io.BytesIO(format_state(s).encode()))
    assert back == PenState(0.125, 0.05, 0.04, True, True, 0.4)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (b"0.1 0.2 0.3\n", "line 1: expected 6 fields"),
        (b"0 0 0 1 1 0\nx 0 0 1 1 0\n", "line 2: not a number"),
        (b"0 nan 0 1 1 0\n", "non-finite"),
        (b"0.2 0 0 1 1 0\n0.1 0 0 1 1 0\n", "line 2: time 0.1 goes back"),
    ],
)
def test_bad_lines_end_the_device_with_a_reason(text: bytes, message: str) -> None:
    with pytest.raises(DeviceError, match=message):
        list(read_states(io.BytesIO(text)))


def test_the_daemon_follows_the_steered_pen() -> None:
    """A drag written to stdin comes back as frames: the pointer sticks, then slips."""
    d = Path(tempfile.mkdtemp(prefix="stc-"))
    pub = f"ipc://{d}/pub"
    cmd = [*DAEMON,
           "--device", "synthetic:stdin", "--clock", "virtual", "--pub", pub,
           "--control", f"ipc://{d}/ctl", "--wait-subscribers", "1", "--no-hotplug"]  # fmt: skip
    ctx = zmq.Context()
    sub = ctx.socket(zmq.SUB)
    sub.setsockopt(zmq.SUBSCRIBE, b"frame.")
    sub.connect(pub)
    states = [PenState(i * 0.005, 0.1, 0.07, i >= 20, True, 0.4) for i in range(40)]
    states += [PenState(0.2 + i * 0.005, 0.1 + i * 2e-4, 0.07, True, True, 0.4) for i in range(80)]
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)  # fmt: skip
    try:
        assert proc.stdin is not None
        proc.stdin.write("".join(format_state(s) for s in states).encode())
        proc.stdin.close()
        phases = []
        while sub.poll(30_000):
            _, payload = sub.recv_multipart()
            frame = protocol.decode_frame(payload)
            assert frame["device"] == "synthetic-stdin"
            phases += [c["phase"] for c in frame["contacts"]]
            if frame["t"] >= 0.58:
                break
        assert proc.wait(30) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        sub.close()
        ctx.term()
    assert phases[0] == "hover"
    assert "stick" in phases and "slip" in phases
    assert phases.index("slip") > phases.index("stick")
