"""A virtual-clock replay holds its first tick for its subscribers (--wait-subscribers)."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import zmq

from stiction import protocol


def _replay(tmp: Path, rec: Path, *extra: str) -> tuple[int, int]:
    """(frames a subscriber received, ticks the daemon ran). The subscriber
    connects only once the daemon says it has started: without a wait, the
    replay may then be over before the subscription reaches it."""
    pub = f"ipc://{tmp}/pub"
    proc = subprocess.Popen(
        [sys.executable, "-m", "stiction.daemon.main", "--clock", "virtual",
         "--device", f"replay:{rec}", "--pub", pub, "--control", f"ipc://{tmp}/ctl", *extra],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stderr is not None
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if " started " in line:
            break
    log: list[str] = []
    drain = threading.Thread(target=lambda: log.extend(proc.stderr or []), daemon=True)
    drain.start()
    ctx = zmq.Context()
    sub = ctx.socket(zmq.SUB)
    sub.rcvhwm = 0
    sub.connect(pub)
    sub.setsockopt(zmq.SUBSCRIBE, protocol.TOPIC_FRAME)
    frames = 0
    try:
        while proc.poll() is None or sub.poll(200):
            if sub.poll(200):
                sub.recv_multipart()
                frames += 1
        drain.join(30)
        err = "".join(lines + log)
    finally:
        sub.close(0)
        ctx.term()
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    ticks = int(err.rsplit("stopped ticks=", 1)[1].split()[0])
    return frames, ticks


def test_every_frame_reaches_a_subscriber_that_connected_first(
    evdev_data: Path, tmp_path: Path
) -> None:
    rec = evdev_data / "wacom-cintiq-13hd-touch-pen.evemu"
    for i in range(3):
        run = tmp_path / str(i)
        run.mkdir()
        frames, ticks = _replay(run, rec, "--wait-subscribers", "1", "--wait-timeout", "60")
        assert frames == ticks > 0


def test_a_wait_that_times_out_starts_anyway(evdev_data: Path, tmp_path: Path) -> None:
    rec = evdev_data / "wacom-cintiq-13hd-touch-pen.evemu"
    done = subprocess.run(
        [sys.executable, "-m", "stiction.daemon.main", "--clock", "virtual",
         "--device", f"replay:{rec}", "--pub", f"ipc://{tmp_path}/p",
         "--control", f"ipc://{tmp_path}/c", "--wait-subscribers", "2", "--wait-timeout", "0.2"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 0 and "starting anyway" in done.stderr


def test_the_publisher_counts_frame_subscribers_only(tmp_path: Path) -> None:
    from stiction.daemon.publisher import Publisher
    from stiction.daemon.security import CurveConfig, Guard

    ctx = zmq.Context()
    pub = Publisher(ctx, f"ipc://{tmp_path}/p", Guard(ctx, CurveConfig()), 100)
    socks = []
    try:
        assert pub.wait_subscribers(1, 0.05) == 0  # nobody: gives up at the timeout
        for topic in (protocol.TOPIC_SCENE, protocol.TOPIC_FRAME + b"pen", b""):
            s = ctx.socket(zmq.SUB)
            s.linger = 0
            s.connect(f"ipc://{tmp_path}/p")
            s.setsockopt(zmq.SUBSCRIBE, topic)
            socks.append(s)
        assert pub.wait_subscribers(2, 10) == 2  # the device's frames and everything
        assert pub.wait_subscribers(1, 0.05) == 0  # the scene-only one never counted
    finally:
        for s in socks:
            s.close(0)
        pub.close()
        ctx.term()
