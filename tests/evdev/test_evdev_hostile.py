"""Hostile recordings (issue 12): huge slot counts, YAML aliases, bad times, long gaps.

Each case is built from a real recording in ../shared/data/evdev with one
thing changed, so the parser gets past the first line before it meets it.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.drivers.evdev.recording import load
from stiction.drivers.limits import MAX_GAP_S, MAX_SLOTS
from stiction.errors import RecordingError

FINGER = "wacom-cintiq-13hd-touch-finger.evemu"
PEN = "wacom-cintiq-13hd-touch-pen.evemu"


def _edited(src: Path, dst: Path, edit) -> Path:  # type: ignore[no-untyped-def]
    dst.write_text("\n".join(edit(src.read_text().splitlines())) + "\n")
    return dst


def test_a_slot_maximum_near_2_31_is_clamped_to_the_kernels_limit(
    evdev_data: Path, tmp_path: Path
) -> None:
    def huge_slots(lines: list[str]) -> list[str]:
        return ["A: 2f 0 2147483646 0 0 0" if line.startswith("A: 2f ") else line for line in lines]

    path = _edited(evdev_data / FINGER, tmp_path / "slots.evemu", huge_slots)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    rec = load(path)
    assert rec.description.num_slots == MAX_SLOTS
    from stiction.drivers.evdev.playback import ReplaySource

    samples = list(ReplaySource(rec).samples())
    assert samples
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # KiB


def test_backwards_time_is_refused_with_its_line(evdev_data: Path, tmp_path: Path) -> None:
    def backwards(lines: list[str]) -> list[str]:
        events = [i for i, line in enumerate(lines) if line.startswith("E:")]
        i = events[len(events) // 2]
        fields = lines[i].split()
        fields[1] = "0.000001"
        lines[i] = " ".join(fields)
        return lines

    path = _edited(evdev_data / PEN, tmp_path / "back.evemu", backwards)
    with pytest.raises(RecordingError, match=r"back\.evemu:\d+: .*runs backwards"):
        load(path)


def test_a_megabyte_line_is_not_repeated_whole_in_the_error(tmp_path: Path) -> None:
    path = tmp_path / "long.evemu"
    path.write_text("Q" * 1_000_000 + "\n")  # was quoted whole: a 1 MB error message
    with pytest.raises(RecordingError) as caught:
        load(path)
    assert str(caught.value).startswith(f"{path}:1: unknown line type")
    assert len(str(caught.value)) < 500


def test_libinput_record_aliases_are_refused_before_expansion(tmp_path: Path) -> None:
    bomb = ["version: 1", "a: &a [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 12):
        bomb.append(f"{chr(97 + i)}: &{chr(97 + i)} [" + ", ".join([f"*{chr(96 + i)}"] * 10) + "]")
    bomb.append("devices: []")
    path = tmp_path / "bomb.yml"
    path.write_text("\n".join(bomb) + "\n")
    with pytest.raises(RecordingError, match="aliases"):
        load(path)


def test_a_fifo_given_as_a_recording_is_refused_unread(tmp_path: Path) -> None:
    fifo = tmp_path / "rec.evemu"
    os.mkfifo(fifo)
    with pytest.raises(RecordingError, match="not a regular file"):
        load(fifo)


def test_a_hid_recording_with_nan_or_backwards_time_is_refused(hid_data: Path) -> None:
    from stiction.drivers.hid.recording import parse_recording

    text = (hid_data / "xp-pen-artist-10s.hid").read_text()
    lines = text.splitlines()
    events = [i for i, line in enumerate(lines) if line.startswith("E:")]
    for bad in ("nan", "0.000000", "inf"):
        edited = list(lines)
        fields = edited[events[5]].split()
        fields[1] = bad
        edited[events[5]] = " ".join(fields)
        with pytest.raises(RecordingError, match=rf"r\.hid:{events[5] + 1}: time"):
            parse_recording("\n".join(edited), "r.hid")


def test_a_billion_second_pause_replays_as_a_short_one_on_the_virtual_clock(
    evdev_data: Path, tmp_path: Path
) -> None:
    def gap(lines: list[str]) -> list[str]:
        out = []
        events = [i for i, line in enumerate(lines) if line.startswith("E:")]
        half = events[len(events) // 2]
        for i, line in enumerate(lines):
            if line.startswith("E:") and i >= half:
                fields = line.split()
                sec, _, usec = fields[1].partition(".")
                fields[1] = f"{int(sec) + 1_000_000_000}.{usec}"
                line = " ".join(fields)
            out.append(line)
        return out

    path = _edited(evdev_data / PEN, tmp_path / "gap.evemu", gap)
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "stiction.daemon.main",
            "--clock",
            "virtual",
            "--device",
            f"replay:{path}",
            "--pub",
            f"ipc://{tmp_path}/pub",
            "--control",
            f"ipc://{tmp_path}/ctl",
            "-v",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "replayed as" in done.stderr
    ticks = int(done.stderr.rsplit("stopped ticks=", 1)[1].split()[0])
    assert ticks < (1 + MAX_GAP_S) * 100 * 2  # the recording's 0.5 s plus one capped pause


def test_a_stiction_recording_or_a_trace_given_as_a_device_recording_is_named(
    tmp_path: Path,
) -> None:
    """stictiond --device replay:FILE read both as evemu: 'unknown line type PK...'."""
    import numpy as np

    npz = tmp_path / "session.npz"
    np.savez(npz, frame_tick=np.arange(3))
    with pytest.raises(RecordingError, match=r"session\.npz is a `stiction record` recording"):
        load(npz)
    (tmp_path / "zipped.evemu").write_bytes(npz.read_bytes())  # the content decides too
    with pytest.raises(RecordingError, match="stiction replay"):
        load(tmp_path / "zipped.evemu")
    trace = tmp_path / "trace.evemu"
    trace.write_text("t,x,y,contact\n0,0,0,1\n")
    with pytest.raises(RecordingError, match=r"is a trace CSV.*stiction simulate"):
        load(trace)


def test_yaml_errors_are_one_line(tmp_path: Path) -> None:
    """PyYAML's message spans three lines; the rule is one line per error."""
    path = tmp_path / "deep.yml"
    path.write_text("version: 1\ndevices: " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(RecordingError) as caught:
        load(path)
    assert "not valid YAML" in str(caught.value) and "\n" not in str(caught.value)
