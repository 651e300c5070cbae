"""The client tools against the real stictiond (synthetic pen, demo scene)."""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from stiction import cli, protocol
from stiction.clients import Frame, SceneMessage, Subscriber, recording
from stiction.clients.replay import Replayer

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
