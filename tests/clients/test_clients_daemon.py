"""The client tools against the real stictiond (synthetic pen, demo scene)."""

from __future__ import annotations

import itertools
import json
import subprocess
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from clients_support import STICTIOND

from stiction import cli, protocol
from stiction.clients import Frame, SceneMessage, Subscriber, recording
from stiction.clients.replay import Replayer

pytest_plugins = ["clients_fixtures"]

pytestmark = pytest.mark.slow


def test_subscriber_clone_pattern_against_the_daemon(stictiond: tuple[str, str]) -> None:
    pub, ctl = stictiond
    with Subscriber(pub) as probe:  # wait until the daemon publishes
        assert isinstance(probe.recv(timeout=30), Frame)
    with Subscriber(pub, control=ctl, kinds=["frame", "scene"]) as sub:
        scene = sub.recv(timeout=10)
        assert isinstance(scene, SceneMessage) and scene.scene["regions"]
        frames = list(sub.frames(count=100, seconds=30))
        ticks = [f.tick for f in frames]
        assert ticks == list(range(ticks[0], ticks[0] + 100))  # no gap, nothing twice
        assert all(b.prev_tick == a.tick for a, b in itertools.pairwise(frames))
        assert sub.stats.bad == 0 and sub.stats.missed == 0


def test_record_and_replay_the_daemon(
    stictiond: tuple[str, str], short_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pub, ctl = stictiond
    with Subscriber(pub) as probe:
        assert isinstance(probe.recv(timeout=30), Frame)
    out = short_dir / "daemon.npz"
    argv = ["record", pub, "--control", ctl, "--out", str(out), "--count", "150"]
    assert cli.main(argv) == 0
    assert "wrote 150 frames" in capsys.readouterr().err
    with np.load(out, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        assert meta["scene"]["regions"] and meta["params"]["params"]["C_l"] > 0
        assert meta["daemon"]["rate"] == 100.0
        assert data["frame_tick"].shape == (150,)
    rec = recording.read(out)
    original = [f.wire for f in rec.frames()]
    rpub = f"ipc://{short_dir}/r-pub"
    player = Replayer(rec, rpub)
    with Subscriber(rpub) as sub:
        box: dict[str, Any] = {}
        t = threading.Thread(
            target=lambda: box.update(ok=player.wait_for_subscriber(30) and player.run(fast=True))
        )
        t.start()
        replayed = [f.wire for f in sub.frames(count=150, seconds=60)]
        t.join(30)
    player.close()
    assert replayed == original
    assert all(w["v"] == protocol.SCHEMA_VERSION for w in replayed)


def test_the_ten_line_example_in_the_docs_runs(
    stictiond: tuple[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    pub, ctl = stictiond
    doc = (Path(__file__).resolve().parents[2] / "docs" / "clients.md").read_text()
    code = doc.split("```python\n", 1)[1].split("```", 1)[0]
    assert len(code.strip().splitlines()) <= 10
    code = code.replace("tcp://127.0.0.1:5556", pub).replace("tcp://127.0.0.1:5557", ctl)
    code = code.replace("seconds=10", "count=30")
    with Subscriber(pub) as probe:
        assert isinstance(probe.recv(timeout=30), Frame)
    exec(compile(code, "docs/clients.md", "exec"), {})
    out = capsys.readouterr().out
    assert "SubscriberStats(" in out and "synthetic-demo" in out


def test_a_daemon_restart_is_only_a_gap(short_dir: Path) -> None:
    pub, ctl = f"ipc://{short_dir}/x-pub", f"ipc://{short_dir}/x-ctl"
    cmd = [
        *(str(STICTIOND), "--clock", "real", "--seconds", "20", "--no-hotplug"),
        *("--device", "synthetic:demo", "--pub", pub, "--control", ctl),
    ]
    log = (short_dir / "x.log").open("wb")
    first = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=log)
    try:
        with Subscriber(pub) as sub:
            before = [(f.prev_tick, f.tick) for f in sub.frames(count=20, seconds=30)]
            first.terminate()
            first.wait(30)
            second = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=log)
            try:
                after = [(f.prev_tick, f.tick) for f in sub.frames(count=20, seconds=30)]
            finally:
                second.terminate()
                second.wait(30)
    finally:
        if first.poll() is None:
            first.kill()
        log.close()
    assert len(before) == 20 and len(after) == 20
    # Frames the old daemon sent before it stopped may still arrive first.
    chain = before + after
    # Each frame names its predecessor's tick; only the restart breaks the chain.
    jumps = [i for i in range(1, len(chain)) if chain[i][0] != chain[i - 1][1]]
    assert len(jumps) == 1, chain  # backwards or forwards: the new daemon's own count
    # The subscriber saw the connection go and come back and did not count the
    # jump to the new daemon's ticks as missed frames.
    st = sub.stats
    assert st.disconnects >= 1 and st.reconnects >= 1 and st.missed == 0 and st.bad == 0
