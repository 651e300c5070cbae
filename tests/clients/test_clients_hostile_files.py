""".npz recordings and record spools that are not what they claim (the audit of issue 12).

Each case once hung or misled: a FIFO named *.npz blocked `stiction replay`
and `stiction trace` in np.load, and `stiction record --recover` in open(); a
few megabytes of zip claiming gigabytes of arrays were inflated whole; a
file that is not a zip made numpy suggest loading it with pickle enabled.
Every one is now a one-line error (exit 2) before anything is read.
"""

from __future__ import annotations

import contextlib
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stiction import cli
from stiction.clients import recording as rec_mod
from stiction.clients import spool
from stiction.errors import RecordingError


def _fails_in_one_line(argv: list[str], words: str, capsys: pytest.CaptureFixture[str]) -> str:
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err, err
    assert len(err.strip().splitlines()) == 1, err
    return err


def test_a_fifo_named_npz_is_refused_by_replay_and_trace_unread(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fifo = tmp_path / "rec.npz"
    os.mkfifo(fifo)  # nobody writes: a blocking open would hang the command forever
    _fails_in_one_line(["replay", str(fifo), "--no-wait"], "not a regular file", capsys)
    out = tmp_path / "t.csv"
    _fails_in_one_line(["trace", str(fifo), "--out", str(out)], "not a regular file", capsys)
    assert not out.exists()


def test_recover_refuses_a_fifo_unread(tmp_path: Path) -> None:
    fifo = tmp_path / "rec.npz.partial"
    os.mkfifo(fifo)
    with pytest.raises(RecordingError, match="not a regular file"):
        spool.recover(fifo, tmp_path / "out.npz")
    assert not (tmp_path / "out.npz").exists()


def test_a_zip_claiming_more_than_the_limit_is_refused_before_inflating(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bomb = tmp_path / "bomb.npz"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zf, zf.open("meta.npy", "w") as m:
        m.write(b"\0" * 4096)
    # The real limit is gigabytes; a small one shows the check, not the memory.
    monkeypatch.setattr(rec_mod, "MAX_NPZ_BYTES", 4095)
    with pytest.raises(RecordingError, match=r"would take 4096 bytes.*MAX_NPZ_BYTES"):
        rec_mod.read(bomb)


def test_a_file_that_is_not_a_zip_never_suggests_unpickling(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"\x80\x04junk that numpy would take for a pickle")
    err = _fails_in_one_line(["replay", str(junk), "--no-wait"], "not a numpy .npz", capsys)
    assert "allow_pickle" not in err and "pickle.load" not in err


def test_an_npz_of_other_arrays_names_what_is_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = tmp_path / "other.npz"
    np.savez(other, x=np.arange(3))
    err = _fails_in_one_line(["replay", str(other), "--no-wait"], "lacks the arrays meta", capsys)
    assert "is not a file in the archive" not in err


@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    raw=st.one_of(
        st.binary(max_size=512),
        st.binary(max_size=256).map(lambda b: b"PK\x03\x04" + b),
        st.binary(max_size=256).map(lambda b: b"\x93NUMPY" + b),
    )
)
def test_any_bytes_are_a_recording_or_one_recording_error(tmp_path: Path, raw: bytes) -> None:
    path = tmp_path / "any.npz"
    path.write_bytes(raw)
    with contextlib.suppress(RecordingError):
        rec_mod.read(path)


@pytest.mark.parametrize(
    ("meta", "op", "check"),
    [
        # the file's params replaced the reply's own v and ok
        ({"params": {"ok": False, "v": 99, "k": 0.1}}, "get_params", {"ok": True, "k": 0.1}),
        # an unhashable device name killed the replay with a TypeError
        ({"devices": [{"name": {"a": 1}}, 5, {"name": "pen", "spec": "x"}]}, "devices", None),
        # an integer msgpack cannot carry raised out of the control loop
        ({"params": {"k": 2**70}}, "get_params", {"ok": False}),
        ({"scene": [1, 2]}, "get_scene", {"ok": False}),
    ],
)
def test_a_recordings_metadata_cannot_break_or_spoof_the_replays_replies(
    tmp_path: Path, meta: dict[str, object], op: str, check: dict[str, object] | None
) -> None:
    import zmq

    from stiction import protocol
    from stiction.clients.replay import Replayer

    path = tmp_path / "evil.npz"
    rec_mod.write(path, [], [], meta)
    ctl = f"ipc://{tmp_path}/ctl"
    player = Replayer(rec_mod.read(path), f"ipc://{tmp_path}/pub", ctl)
    ctx = zmq.Context.instance()
    req = ctx.socket(zmq.REQ)
    req.linger = 0
    try:
        req.connect(ctl)
        req.send(protocol.make_request(op))
        for _ in range(100):  # the request is queued: a few polls answer it
            player.service(0.1)
            if req.poll(0):
                break
        reply = protocol.decode(req.recv(zmq.NOBLOCK))
    finally:
        req.close()
        player.close()
    if check is None:
        assert reply["ok"] is True and [d["name"] for d in reply["devices"]] == ["pen"]
    else:
        assert {k: reply.get(k) for k in check} == check and reply["v"] == 1


def test_a_recording_whose_meta_is_nested_thousands_deep_is_one_error(tmp_path: Path) -> None:
    """json.loads raised RecursionError, which no handler expected: a traceback."""
    path = tmp_path / "deep.npz"
    np.savez(path, meta=np.asarray("[" * 100_000))
    with pytest.raises(RecordingError, match="nested too deeply"):
        rec_mod.read(path)
