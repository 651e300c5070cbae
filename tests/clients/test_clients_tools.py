"""stiction listen / record / replay, driven through the real CLI and real sockets."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from clients_support import SCENE, FakeDaemon, make_frame, run_in_thread, scene_message, stroke

from stiction import cli, protocol
from stiction.clients import Frame, SceneMessage, Subscriber, control, spool
from stiction.clients import recording as rec_mod
from stiction.clients.record import record
from stiction.clients.replay import Replayer
from stiction.errors import ProtocolError, RecordingError

pytest_plugins = ["clients_fixtures"]


def test_listen_json_prints_the_wire_frames(
    daemon: FakeDaemon, capsys: pytest.CaptureFixture[str]
) -> None:
    frames = stroke(3)
    t, box = run_in_thread(cli.main, ["listen", daemon.pub_endpoint, "--json", "--count", "3"])
    daemon.wait_subscribers()
    for f in frames:
        daemon.send(f)
    t.join(30)
    assert box.get("result") == 0, box
    lines = capsys.readouterr().out.splitlines()
    assert [json.loads(line) for line in lines] == frames


def test_listen_human_lines(daemon: FakeDaemon, capsys: pytest.CaptureFixture[str]) -> None:
    t, box = run_in_thread(cli.main, ["listen", daemon.pub_endpoint, "--count", "2", "--scenes"])
    daemon.wait_subscribers(2)
    daemon.send(scene_message(0))
    daemon.send(make_frame(0))
    daemon.send(stroke(4)[1])
    t.join(30)
    assert box.get("result") == 0, box
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("scene 'test scene' (tick 0): 3 regions")
    assert "(no contact)" in out[1]
    assert "#0 stick" in out[2] and "pointer (  100.0,   150.0) px" in out[2]


def test_listen_says_when_nothing_arrives(
    endpoints: tuple[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main(["listen", endpoints[0], "--seconds", "0.1"]) == 1
    assert "is stictiond running?" in capsys.readouterr().err


def test_listen_refuses_a_newer_schema_in_one_line(
    daemon: FakeDaemon, capsys: pytest.CaptureFixture[str]
) -> None:
    t, box = run_in_thread(cli.main, ["listen", daemon.pub_endpoint, "--count", "1"])
    daemon.wait_subscribers()
    daemon.send({**make_frame(0), "v": 99})
    t.join(30)
    assert box.get("result") == 2
    err = capsys.readouterr().err
    assert err.startswith("stiction: error:") and "schema version 99" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_cli_rejects_bad_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main(["listen", "--count", "-3"])
    assert exc.value.code == 2
    assert "argument --count: must be at least 1" in capsys.readouterr().err


def _record_stroke(daemon: FakeDaemon, out: Path, n: int = 40) -> Any:
    t, box = run_in_thread(
        record,
        daemon.pub_endpoint,
        out,
        control_endpoint=daemon.control_endpoint,
        count=n,
        seconds=60,
    )
    daemon.wait_subscribers(2)  # frames and scene
    daemon.send(scene_message(-1))
    for f in stroke(n):
        daemon.send(f)
    t.join(60)
    assert "error" not in box, box
    return box["result"]


def test_record_writes_columns_and_metadata(daemon: FakeDaemon, short_dir: Path) -> None:
    out = short_dir / "stroke.npz"
    result = _record_stroke(daemon, out)
    assert result.frames == 40 and result.contacts == 40 and result.scenes >= 1
    # Analysis tools read it with plain numpy, no pickle, no stiction.
    with np.load(out, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        assert meta["format"] == "stiction-recording"
        assert meta["scene"] == SCENE
        assert meta["params"]["params"]["C_l"] == 2000.0
        assert data["tick"].tolist() == list(range(40))
        assert data["pointer_px"].shape == (40, 2)
        assert data["phase"][:20].tolist() == ["stick"] * 20
        assert np.allclose(data["touch_px"][:, 0], 100 + 2 * np.arange(40))
    assert daemon.requests[:1] == ["ping"] and "snapshot" in daemon.requests


def test_record_without_control_says_why(endpoints: tuple[str, str], short_dir: Path) -> None:
    d = FakeDaemon(endpoints[0])
    try:
        t, _ = run_in_thread(
            record, d.pub_endpoint, short_dir / "r.npz", control_endpoint=None, count=2
        )
        d.wait_subscribers(2)
        d.send(make_frame(0))
        d.send(make_frame(1))
        t.join(30)
    finally:
        d.close()
    rec = rec_mod.read(short_dir / "r.npz")
    assert rec.meta["control_error"] == "no control endpoint given"
    assert rec.table.frame_count == 2 and len(rec.table) == 0


def test_record_then_replay_gives_the_same_stream(daemon: FakeDaemon, short_dir: Path) -> None:
    out = short_dir / "stroke.npz"
    _record_stroke(daemon, out)
    rec = rec_mod.read(out)
    pub, ctl = f"ipc://{short_dir}/replay", f"ipc://{short_dir}/replay-ctl"
    player = Replayer(rec, pub, ctl)
    done = threading.Event()

    def play() -> None:
        assert player.wait_for_subscriber(10)
        player.run(speed=20.0)  # paced by the frames' own t, 20x
        player.hold(done.is_set, 60)

    with Subscriber(pub, kinds=["frame", "scene"]) as sub:
        t, box = run_in_thread(play)
        got = [sub.recv(timeout=10) for _ in range(len(rec))]
    try:
        snap = control.request(ctl, "snapshot", timeout=5)
        scene = control.request(ctl, "get_scene", timeout=5)
        with pytest.raises(ProtocolError, match="read-only"):
            control.request(ctl, "set_params", timeout=5, k=1.0)
    finally:
        done.set()
        t.join(10)
        player.close()
    assert "error" not in box, box
    assert isinstance(got[0], SceneMessage) and got[0].scene == SCENE
    frames = [m for m in got if isinstance(m, Frame)]
    assert [f.wire for f in frames] == stroke(40)
    assert snap["tick"] == 39 and snap["frames"]["pen"] == stroke(40)[-1]
    assert scene["scene"] == SCENE


def test_replay_cli_fast(daemon: FakeDaemon, short_dir: Path) -> None:
    out = short_dir / "stroke.npz"
    _record_stroke(daemon, out, n=10)
    pub = f"ipc://{short_dir}/cli-replay"
    with Subscriber(pub) as sub:
        t, box = run_in_thread(
            cli.main, ["replay", str(out), "--pub", pub, "--fast", "--wait", "30"]
        )
        ticks = [f.tick for f in sub.frames(count=10, seconds=30)]
        t.join(30)
    assert box.get("result") == 0 and ticks == list(range(10))


def test_replay_refuses_bad_files(short_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = short_dir / "bad.npz"
    bad.write_bytes(b"PK\x03\x04 not really a zip")
    plain = short_dir / "plain.npz"
    np.savez(plain, x=np.arange(3))
    for path, words in (
        (short_dir / "missing.npz", "no such file"),
        (bad, "not a numpy .npz recording"),
        (plain, "lacks the array"),
    ):
        assert cli.main(["replay", str(path), "--no-wait", "--pub", "inproc://x"]) == 2
        err = capsys.readouterr().err
        assert words in err and "Traceback" not in err, err
    with pytest.raises(RecordingError, match="name it"):
        rec_mod.write(short_dir / "x.csv", [], [], {})


def test_replay_refuses_a_corrupted_message(daemon: FakeDaemon, short_dir: Path) -> None:
    out = short_dir / "stroke.npz"
    _record_stroke(daemon, out, n=5)
    with np.load(out) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["messages"] = arrays["messages"].copy()
    arrays["messages"][arrays["message_offsets"][2]] = 0xC1  # never valid msgpack
    broken = short_dir / "broken.npz"
    np.savez(broken, **arrays)
    with pytest.raises(RecordingError, match="message 2"):
        rec_mod.check_messages(rec_mod.read(broken), str(broken))


def test_replay_publishes_extra_keys_unchanged(endpoints: tuple[str, str], short_dir: Path) -> None:
    msgs = [(b"frame.pen", protocol.encode(make_frame(0, future_key={"a": 1})), 0.0)]
    frame = Frame.from_wire(protocol.decode_frame(msgs[0][1]))
    rec_mod.write(short_dir / "x.npz", msgs, [frame], {})
    rec = rec_mod.read(short_dir / "x.npz")
    assert next(rec.frames()).wire["future_key"] == {"a": 1}


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_record_writes_the_file_when_stopped_by_a_signal(
    daemon: FakeDaemon, short_dir: Path, sig: signal.Signals
) -> None:
    out = short_dir / f"sig-{sig.name}.npz"
    proc = subprocess.Popen(
        [
            *(str(Path(sys.executable).with_name("stiction")), "-v", "-v", "record"),
            *(daemon.pub_endpoint, "--out", str(out), "--control", daemon.control_endpoint),
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    watchdog = threading.Timer(60, proc.kill)
    watchdog.start()
    try:
        daemon.wait_subscribers(2)  # it is recording
        for f in stroke(5):
            daemon.send(f)
        assert proc.stderr is not None
        seen = []  # the debug log says when the five frames are in the spool
        for line in iter(proc.stderr.readline, ""):
            seen.append(line)
            if "spooled 5 frames" in line:
                break
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
    finally:
        watchdog.cancel()
    err = "".join(seen) + err
    assert proc.returncode == 0, err
    rec = rec_mod.read(out)
    assert rec.meta["scene"] == SCENE and rec.table.frame_count == 5
    assert f"wrote 5 frames (5 contacts, 1 scene messages) to {out}" in err, err


def test_record_fails_and_writes_nothing_when_no_frame_came(
    daemon: FakeDaemon, short_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The daemon answers but publishes nothing (here: no device): exit 1, no file,
    and the reason in words."""
    out = short_dir / "empty.npz"
    argv = ["record", daemon.pub_endpoint, "--out", str(out), "--control"]
    assert cli.main([*argv, daemon.control_endpoint, "--seconds", "0.3"]) == 1
    err = capsys.readouterr().err
    assert "no frame arrived in 0." in err and "nothing was written to" in err
    assert "is up but reads no device" in err, err  # FakeDaemon's devices reply lists none
    assert not out.exists() and not spool.spool_path(out).exists()


def test_curve_flags_come_in_pairs(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["listen", "--curve-server-key", "x.key", "--seconds", "1"]) == 2
    assert "give both --curve-server-key and --curve-client-key" in capsys.readouterr().err


def test_record_refuses_to_overwrite_a_recording_without_force(tmp_path: Path) -> None:
    import subprocess
    import sys

    out = tmp_path / "session.npz"
    out.write_bytes(b"someone's data")
    done = subprocess.run(
        [sys.executable, "-m", "stiction", "record", f"ipc://{tmp_path}/nobody", "--out", str(out),
         "--no-control", "--seconds", "0.1"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2 and "--force" in done.stderr
    assert out.read_bytes() == b"someone's data"
