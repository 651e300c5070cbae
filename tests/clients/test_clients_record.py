"""stiction record writes as it goes: memory holds one chunk, a killed recorder
leaves a spool that recovers into the recording a clean stop would have made,
and a spool assembled from any chunking equals the in-memory writer's file."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import zipfile
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from clients_support import (
    SCENE,
    FakeDaemon,
    make_contact,
    make_frame,
    run_in_thread,
    scene_message,
    stroke,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stiction import cli, protocol
from stiction.clients import Frame, SceneMessage, spool
from stiction.clients import record as record_mod
from stiction.clients import recording as rec_mod
from stiction.clients.messages import Message, parse_message
from stiction.clients.record import record
from stiction.errors import RecordingError

pytest_plugins = ["clients_fixtures"]

STICTION = str(Path(sys.executable).with_name("stiction"))
STATS = {"received": 7, "bad": 0}
START_META = {"endpoint": "ipc://x", "control": None, "control_error": "none given"}


def as_message(wire: dict[str, Any], recv_t: float) -> tuple[bytes, bytes, float, Message]:
    """What the recorder hands the spool for one received message."""
    topic = protocol.frame_topic(wire["device"]) if wire["kind"] == "frame" else b"scene"
    payload = protocol.encode(wire)
    return topic, payload, recv_t, parse_message(topic, payload)


def expected_meta(msgs: list[tuple[bytes, bytes, float, Message]]) -> dict[str, Any]:
    """The metadata the recorder writes for these messages (record.py before the spool)."""
    scenes = [{"tick": m.tick, "scene": m.scene} for *_, m in msgs if isinstance(m, SceneMessage)]
    meta: dict[str, Any] = dict(START_META)
    if scenes:
        meta["scene"] = scenes[0]["scene"]
    meta.update(scene_changes=scenes, subscriber_stats=STATS, duration_s=2.5)
    return meta


def in_memory(path: Path, msgs: list[tuple[bytes, bytes, float, Message]]) -> Path:
    frames = [m for *_, m in msgs if isinstance(m, Frame)]
    return rec_mod.write(path, [(t, p, r) for t, p, r, _ in msgs], frames, expected_meta(msgs))


def spooled(
    path: Path, msgs: list[tuple[bytes, bytes, float, Message]], flush_after: set[int]
) -> spool.SpoolWriter:
    """A spool of ``msgs`` flushed after the given message indexes (not yet finished)."""
    writer = spool.SpoolWriter.create(spool.spool_path(path), fsync=False)
    writer.write_meta(START_META)
    for i, (topic, payload, recv_t, msg) in enumerate(msgs):
        writer.add(topic, payload, recv_t, msg)
        if i in flush_after:
            writer.flush(STATS, 2.5)
    return writer


def arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def assert_same_recording(got: Path, want: Path, *, ignore: tuple[str, ...] = ()) -> None:
    a, b = arrays(got), arrays(want)
    assert sorted(a) == sorted(b)
    for name in b:
        if name == "meta":
            continue
        assert a[name].dtype == b[name].dtype, name
        assert a[name].shape == b[name].shape, name
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    meta_a, meta_b = json.loads(str(a["meta"])), json.loads(str(b["meta"]))
    for key in ignore:
        meta_a.pop(key, None)
        meta_b.pop(key, None)
    assert meta_a == meta_b
    rec = rec_mod.read(got)  # and the readers take it
    rec_mod.check_messages(rec, str(got))


def stroke_messages(n: int) -> list[tuple[bytes, bytes, float, Message]]:
    wires = [scene_message(-1), *stroke(n)]
    return [as_message(w, 0.01 * i) for i, w in enumerate(wires)]


# -- the spool on its own ---------------------------------------------------


def test_a_clean_finish_writes_the_recording_and_deletes_the_spool(short_dir: Path) -> None:
    msgs = stroke_messages(20)
    writer = spooled(short_dir / "s.npz", msgs, flush_after={4, 9, 15})
    summary = writer.finish(short_dir / "s.npz", STATS, 2.5)
    assert (summary.frames, summary.contacts, summary.scene_count) == (20, 20, 1)
    assert not spool.spool_path(short_dir / "s.npz").exists()
    assert sorted(p.name for p in short_dir.iterdir()) == ["s.npz"]  # no temporary left
    assert_same_recording(short_dir / "s.npz", in_memory(short_dir / "m.npz", msgs))
    # Written as np.savez_compressed writes: deflated members, readable by np.load.
    with zipfile.ZipFile(short_dir / "s.npz") as zf:
        assert {i.compress_type for i in zf.infolist()} == {zipfile.ZIP_DEFLATED}


def test_a_killed_writer_recovers_into_what_a_clean_stop_gives(short_dir: Path) -> None:
    msgs = stroke_messages(30)
    killed = spooled(short_dir / "k.npz", msgs, flush_after={9, 19})
    killed.close()  # what the kernel does to a SIGKILLed recorder: messages 20.. unflushed
    part = spool.spool_path(short_dir / "k.npz")
    with part.open("ab") as fh:  # and a chunk that was being written when it died
        fh.write(b"SREC\x10\x00\x00\x00" + b"\xff" * 11)
    summary = spool.recover(part)
    assert summary.output == short_dir / "k.npz" and not part.exists()
    assert (summary.frames, summary.chunks, summary.final) == (19, 2, False)
    assert summary.size - summary.end == 19

    clean = spooled(short_dir / "c.npz", msgs[:20], flush_after={9})
    clean.finish(short_dir / "c.npz", STATS, 2.5)
    assert_same_recording(short_dir / "k.npz", short_dir / "c.npz", ignore=("recovered",))
    meta = rec_mod.read(short_dir / "k.npz").meta
    assert meta["recovered"]["complete"] is False and meta["recovered"]["chunks"] == 2
    assert meta["recovered"]["spool"] == str(part) and meta["scene"] == SCENE
    assert meta["frames"] == 19 and meta["messages"] == 20


def test_flushed_data_survives_a_torn_or_corrupted_chunk(short_dir: Path) -> None:
    msgs = stroke_messages(12)
    writer = spooled(short_dir / "t.npz", msgs, flush_after={5, 12})
    writer.close()
    part = spool.spool_path(short_dir / "t.npz")
    data = bytearray(part.read_bytes())
    data[-3] ^= 0xFF  # the last chunk's body no longer matches its CRC
    part.write_bytes(bytes(data))
    summary = spool.recover(part, short_dir / "out.npz")
    assert summary.frames == 5 and summary.chunks == 1
    assert rec_mod.read(short_dir / "out.npz").table.frame_tick.tolist() == list(range(5))


def test_a_whole_chunk_it_cannot_understand_ends_what_is_recovered(short_dir: Path) -> None:
    """A record whose CRC holds but whose columns make no sense (a bug, another
    version) is where recovery stops, keeping every chunk before it."""
    writer = spooled(short_dir / "u.npz", stroke_messages(6), flush_after={3, 6})
    writer.close()
    head = json.dumps({"kind": "chunk", "columns": [["tick", "|O", [1]]]}).encode()
    record = spool._HEAD.pack(spool._TAG, len(head), 0, zlib.crc32(head)) + head
    with writer.path.open("ab") as fh:
        fh.write(record)
    summary = spool.recover(writer.path)
    assert (summary.chunks, summary.frames, summary.size - summary.end) == (2, 6, len(record))


def test_recover_refuses_what_it_cannot_or_must_not_do(short_dir: Path) -> None:
    writer = spooled(short_dir / "r.npz", stroke_messages(3), flush_after={1})
    part = writer.path
    with pytest.raises(RecordingError, match="a running `stiction record` is still writing it"):
        spool.recover(part)  # its writer holds the lock
    with pytest.raises(RecordingError, match="exists: another `stiction record`"):
        spool.SpoolWriter.create(part)
    writer.close()
    (short_dir / "r.npz").write_bytes(b"an older recording")
    with pytest.raises(RecordingError, match="never replaces a recording"):
        spool.recover(part)
    with pytest.raises(RecordingError, match="name it"):
        spool.recover(part, short_dir / "r.csv")
    with pytest.raises(RecordingError, match="no such spool"):
        spool.recover(short_dir / "missing.npz.partial")
    (short_dir / "junk.partial").write_bytes(b"PK\x03\x04 a zip, not a spool")
    with pytest.raises(RecordingError, match="not a stiction recording spool"):
        spool.recover(short_dir / "junk.partial")
    assert spool.recover(part, overwrite=True).frames == 1  # the flushed chunk


def test_memory_holds_one_chunk_at_a_time(
    daemon: FakeDaemon, short_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """record() flushes every ``chunk`` messages, never holding more."""
    flushes: list[tuple[int, bool]] = []
    added = threading.Semaphore(0)
    flushed = threading.Semaphore(0)
    real_add, real_flush = spool.SpoolWriter.add, spool.SpoolWriter.flush

    def add(self: spool.SpoolWriter, *args: Any) -> None:
        assert self.pending < 4
        real_add(self, *args)
        added.release()

    def flush(self: spool.SpoolWriter, *args: Any, final: bool = False) -> None:
        flushes.append((self.pending, final))
        real_flush(self, *args, final=final)
        flushed.release()

    monkeypatch.setattr(spool.SpoolWriter, "add", add)
    monkeypatch.setattr(spool.SpoolWriter, "flush", flush)
    stop = threading.Event()
    out = short_dir / "chunked.npz"
    t, box = run_in_thread(
        record, daemon.pub_endpoint, out, chunk=4, flush_every=3600, stop=stop, fsync=False
    )
    daemon.wait_subscribers(2)
    for f in stroke(10):
        daemon.send(f)
    for _ in range(10):
        assert added.acquire(timeout=30)
    assert flushed.acquire(timeout=30) and flushed.acquire(timeout=30)
    with spool.spool_path(out).open("rb") as fh:  # the two chunks are on disk already
        assert spool.scan(fh, spool.spool_path(out)).frames == 8
    stop.set()
    t.join(30)
    assert "error" not in box, box
    assert flushes == [(4, False), (4, False), (2, True)]
    assert box["result"].frames == 10 and not spool.spool_path(out).exists()
    assert [f.wire for f in rec_mod.read(out).frames()] == stroke(10)


def test_a_slow_trickle_is_flushed_every_flush_every_seconds(
    daemon: FakeDaemon, short_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A frame waits at most ``flush_every`` seconds for its chunk to be written
    (the recorder's clock is a fake one the test moves)."""
    clock = {"now": 1000.0}

    class FakeTime:
        @staticmethod
        def monotonic() -> float:
            return clock["now"]

    added, flushed = threading.Semaphore(0), threading.Semaphore(0)
    real_add, real_flush = spool.SpoolWriter.add, spool.SpoolWriter.flush

    def add(self: spool.SpoolWriter, *args: Any) -> None:
        real_add(self, *args)
        added.release()

    def flush(self: spool.SpoolWriter, *args: Any, final: bool = False) -> None:
        real_flush(self, *args, final=final)
        flushed.release()

    monkeypatch.setattr(record_mod, "time", FakeTime)
    monkeypatch.setattr(spool.SpoolWriter, "add", add)
    monkeypatch.setattr(spool.SpoolWriter, "flush", flush)
    out = short_dir / "trickle.npz"
    stop = threading.Event()
    t, box = run_in_thread(record, daemon.pub_endpoint, out, flush_every=5.0, stop=stop)
    daemon.wait_subscribers(2)
    daemon.send(make_frame(0))
    assert added.acquire(timeout=30)
    clock["now"] += 5.0
    assert flushed.acquire(timeout=30)  # within one poll (0.2 s) of the recorder
    with spool.spool_path(out).open("rb") as fh:
        summary = spool.scan(fh, spool.spool_path(out))
    # One chunk, flushed when the clock said 5 s (not when the frame came, at 0 s).
    assert (summary.chunks, summary.frames, summary.duration_s) == (1, 1, 5.0)
    stop.set()
    t.join(30)
    assert "error" not in box, box


# -- the recorder, killed and stopped for real --------------------------------


def _stderr_lines(proc: subprocess.Popen[str]) -> Iterator[str]:
    assert proc.stderr is not None
    yield from iter(proc.stderr.readline, "")


def test_a_sigkilled_recorder_is_recovered_from_its_spool(
    daemon: FakeDaemon, short_dir: Path
) -> None:
    out = short_dir / "killed.npz"
    script = (
        "import logging, sys\n"
        "from stiction.clients.record import record\n"
        "logging.basicConfig(level=logging.DEBUG, stream=sys.stderr)\n"
        "record(sys.argv[1], sys.argv[2], control_endpoint=sys.argv[3], chunk=4, "
        "flush_every=3600)\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", script, daemon.pub_endpoint, str(out), daemon.control_endpoint],
        stderr=subprocess.PIPE,
        text=True,
    )
    watchdog = threading.Timer(60, proc.kill)
    watchdog.start()
    flushed = 0
    try:
        daemon.wait_subscribers(2)
        # Scene + 9 frames: chunks of four flush after frames 3 and 7; the
        # last two never fill a chunk, so exactly 7 can be on disk at the kill.
        frames = stroke(9)
        for f in frames:
            daemon.send(f)
        for line in _stderr_lines(proc):
            found = re.search(r"spooled (\d+) frames", line)
            flushed = int(found.group(1)) if found else flushed
            if flushed >= 7:  # two chunks of four messages (the snapshot's scene first)
                break
        proc.send_signal(signal.SIGKILL)  # with the rest still pending in memory
        proc.wait(30)
    finally:
        watchdog.cancel()
        proc.kill()
    assert proc.returncode == -signal.SIGKILL and flushed in (7, 8)
    part = spool.spool_path(out)
    assert part.exists() and not out.exists()

    done = subprocess.run(
        [sys.executable, "-m", "stiction", "record", "--recover", str(part)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert f"recovered {flushed} frames" in done.stderr and str(out) in done.stderr
    assert "Traceback" not in done.stderr and not part.exists()
    rec = rec_mod.read(out)
    assert [f.wire for f in rec.frames()] == frames[:flushed]
    assert rec.meta["scene"] == SCENE and rec.meta["params"]["params"]["C_l"] == 2000.0
    assert rec.meta["recovered"]["complete"] is False

    again = subprocess.run(
        [sys.executable, "-m", "stiction.clients.record", "--recover", str(part)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert again.returncode == 2 and "no such spool" in again.stderr
    assert "Traceback" not in again.stderr


def test_the_next_recorder_recovers_a_leftover_spool(
    daemon: FakeDaemon, short_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = short_dir / "trial.npz"
    msgs = stroke_messages(6)
    spooled(out, msgs, flush_after={5}).close()  # a killed session: 5 frames flushed
    (short_dir / "trial.recovered.npz").write_bytes(b"taken")
    t, box = run_in_thread(
        cli.main, ["record", daemon.pub_endpoint, "--out", str(out), "--count", "2"]
    )
    daemon.wait_subscribers(2)
    daemon.send(make_frame(0))
    daemon.send(make_frame(1))
    t.join(30)
    assert box.get("result") == 0, box
    err = capsys.readouterr().err
    assert f"recovered the session a killed recorder left to {short_dir}/trial.recovered-2" in err
    old = rec_mod.read(short_dir / "trial.recovered-2.npz")
    assert old.table.frame_count == 5 and old.meta["recovered"]["complete"] is False
    assert rec_mod.read(out).table.frame_tick.tolist() == [0, 1]
    assert not spool.spool_path(out).exists()


def test_an_unwritable_path_is_one_clear_line(
    short_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (short_dir / "file").write_text("not a directory")
    out = short_dir / "file" / "x.npz"
    assert cli.main(["record", "inproc://nothing", "--out", str(out), "--no-control"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("stiction: error:") and f"{out}.partial: cannot create the spool" in err
    assert "Not a directory" in err and len(err.strip().splitlines()) == 1


def test_a_full_disk_stops_the_recorder_and_keeps_the_spool(
    daemon: FakeDaemon, short_dir: Path
) -> None:
    """RLIMIT_FSIZE makes writes past a size fail (EFBIG) as a full disk would."""
    out = short_dir / "full.npz"
    frames = stroke(3000)
    probe = spooled(short_dir / "probe.npz", [as_message(f, 0.0) for f in frames[:1000]], set())
    probe.flush(STATS, 1.0)
    size = int(1.5 * probe.path.stat().st_size)  # room for one full chunk, not two
    probe.discard()

    def limit() -> None:
        import resource

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write, do not kill
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    proc = subprocess.Popen(
        [STICTION, "record", daemon.pub_endpoint, "--out", str(out), "--no-control"],
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=limit,
    )
    try:
        daemon.wait_subscribers(2)
        for f in frames:
            daemon.send(f)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 2, err
    part = spool.spool_path(out)
    assert err.startswith("stiction: error:") and "Traceback" not in err
    assert f"{part}: cannot write the recording spool (File too large)" in err
    assert f"stiction record --recover {part}" in err
    assert part.exists() and not out.exists()
    summary = spool.recover(part)  # whatever was flushed before is intact
    got = [f.wire for f in rec_mod.read(out).frames()]
    assert summary.frames > 0 and got == frames[: summary.frames]


def test_a_newer_schema_stops_the_recorder_but_writes_what_came_before(
    daemon: FakeDaemon, short_dir: Path
) -> None:
    out = short_dir / "newer.npz"
    t, box = run_in_thread(record, daemon.pub_endpoint, out, count=10)
    daemon.wait_subscribers(2)
    daemon.send(make_frame(0))
    daemon.send({**make_frame(1), "v": 99})
    t.join(30)
    assert isinstance(box.get("error"), RecordingError), box
    assert "schema version 99" in str(box["error"]) and f"written to {out}" in str(box["error"])
    assert rec_mod.read(out).table.frame_tick.tolist() == [0]
    assert not spool.spool_path(out).exists()


# -- spooled and assembled equals in memory, for any frames and any chunking --

DEVICES = ["pen", "touch-screen-0", "é", ""]
MATERIALS = ["sticky", "a", "slippery-but-longer"]


@st.composite
def wire_messages(draw: st.DrawFn) -> dict[str, Any]:
    if draw(st.integers(0, 9)) == 0:
        return scene_message(draw(st.integers(-1, 100)))
    coords = st.floats(-1e4, 1e4, allow_nan=False)
    contacts = [
        make_contact(
            (draw(coords), draw(coords)),
            (draw(coords), draw(coords)),
            draw(st.sampled_from(protocol.PHASES)),
            string=draw(st.booleans()),
            cid=draw(st.integers(0, 2**40)),
        )
        | {"material": draw(st.sampled_from(MATERIALS))}
        for _ in range(draw(st.integers(0, 3)))
    ]
    frame = make_frame(draw(st.integers(0, 2**40)), draw(st.sampled_from(DEVICES)), contacts)
    if draw(st.booleans()):
        frame["t_input"] = None
    return frame


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    wires=st.lists(wire_messages(), max_size=25),
    cuts=st.sets(st.integers(0, 30)),
)
def test_spooled_and_assembled_equals_in_memory(
    wires: list[dict[str, Any]], cuts: set[int]
) -> None:
    msgs = [as_message(w, 0.5 * i) for i, w in enumerate(wires)]
    with tempfile.TemporaryDirectory(prefix="stc-prop-") as tmp:
        d = Path(tmp)
        spooled(d / "s.npz", msgs, flush_after=cuts).finish(d / "s.npz", STATS, 2.5)
        assert_same_recording(d / "s.npz", in_memory(d / "m.npz", msgs))
        assert sorted(os.listdir(d)) == ["m.npz", "s.npz"]
