"""The session state machine and its files: rows on disk per trial, pause/resume, resuming."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest

from stiction.experiment import data
from stiction.experiment.runner import AnswerError, Session
from stiction.experiment.study import load_study


def frame(t: float, phase: str | None, pointer: tuple[float, float], touch: tuple[float, float],
          string: float | None = None) -> dict[str, Any]:  # fmt: skip
    if phase is None:
        return {"t": t, "contacts": []}
    c: dict[str, Any] = {"phase": phase, "pointer_px": list(pointer), "touch_px": list(touch)}
    if string is not None:
        c["string"] = {"length_px": string, "dir": [1.0, 0.0]}
    return {"t": t, "contacts": [c]}


def stroke(session: Session, t: float, gap: float) -> float:
    """One stimulus: lift, touch down at the dot, stick `gap` px, slide 80 px."""
    cx, cy = session.study.display[0] / 2, session.study.display[1] / 2
    assert session.pending_scene() is not None
    session.scene_applied()
    assert not session.on_frame(frame(t, None, (0, 0), (0, 0)))
    assert not session.on_frame(frame(t + 0.01, "stick", (cx, cy), (cx, cy), 0.0))
    assert not session.on_frame(frame(t + 0.02, "stick", (cx, cy), (cx + gap, cy), gap / 2))
    assert session.on_frame(frame(t + 0.03, "slip", (cx + 80, cy), (cx + 85, cy), 3.0))
    return t + 0.1


def test_a_trial_is_on_disk_when_answered(tmp_path: Path) -> None:
    clock = [0.0]
    s = Session(load_study("paper-study1").with_repetitions(1), "P01", tmp_path,
                clock=lambda: clock[0])  # fmt: skip
    assert s.state == "instructions" and s.buttons() == ["start"]
    s.press("start")
    t = stroke(s, 0.0, 30.0)
    t = stroke(s, t, 10.0)
    assert s.state == "answer" and s.buttons() == ["first", "second"]
    clock[0] = 1.25
    s.press("first")
    rows = list(csv.DictReader((tmp_path / "P01.csv").open()))  # another handle: on disk
    assert len(rows) == 1
    r = rows[0]
    trial = s.schedule[0]
    assert r["trial"] == "1" and r["condition"] == trial.condition
    assert r["chose_comparison"] == ("1" if trial.comparison_first else "0")
    assert float(r["response_time_s"]) == pytest.approx(1.25)
    gap_comp = 30.0 if trial.comparison_first else 10.0
    assert float(r["max_pointer_touch_px"]) == pytest.approx(gap_comp)
    assert r["ratio"] == "" and r["adjustments"] == ""
    assert list(rows[0])[: len(data.COLUMNS)] == list(data.COLUMNS)
    s.close()


def test_ratio_buttons_adjust_and_confirm(tmp_path: Path) -> None:
    s = Session(load_study("paper-study2").with_repetitions(1), "P02", tmp_path)
    s.press("start")
    t = stroke(s, 0.0, 20.0)
    stroke(s, t, 25.0)
    assert s.buttons() == ["-0.10", "-0.05", "-0.01", "+0.01", "+0.05", "+0.10", "confirm"]
    for b in ("+0.10", "+0.05", "-0.01"):
        s.press(b)
    assert s.view()["ratio"] == 1.14
    with pytest.raises(AnswerError):
        s.press("first")
    s.press("confirm")
    row = data.read_trials([tmp_path / "P02.csv"])[0]
    assert row["ratio"] == pytest.approx(1.14)
    assert row["adjustments"] == "+0.10 +0.05 -0.01"
    assert row["chose_comparison"] is None
    s.close()


def test_a_stimulus_needs_a_fresh_touch_down_at_the_dot(tmp_path: Path) -> None:
    s = Session(load_study("paper-study1").with_repetitions(1), "P01", tmp_path)
    s.press("start")
    s.scene_applied()
    cx, cy = 1440, 900
    # still down from before: ignored until the pen has been lifted
    assert not s.on_frame(frame(0.0, "stick", (cx, cy), (cx, cy)))
    assert not s.on_frame(frame(0.01, "slip", (cx + 90, cy), (cx + 90, cy)))
    assert not s.on_frame(frame(0.02, "hover", (cx, cy), (cx, cy)))
    # a touch-down far from the dot does not start it either
    assert not s.on_frame(frame(0.03, "stick", (cx + 300, cy), (cx + 300, cy)))
    assert not s.on_frame(frame(0.04, "slip", (cx + 400, cy), (cx + 400, cy)))
    assert s.stimulus is not None and s.stimulus.index == 0
    s.close()


def test_pause_and_resume_restart_the_interrupted_trial(tmp_path: Path) -> None:
    s = Session(load_study("paper-study1").with_repetitions(1), "P01", tmp_path)
    s.press("start")
    stroke(s, 0.0, 20.0)  # first stimulus done
    assert s.stimulus is not None and s.stimulus.index == 1
    s.pause()
    assert s.state == "paused" and s.buttons() == []
    assert s.view()["text"].startswith("Paused")
    with pytest.raises(AnswerError):
        s.press("first")
    s.resume()
    assert s.state == "stimulus" and s.stimulus is not None and s.stimulus.index == 0
    t = stroke(s, 1.0, 20.0)
    stroke(s, t, 20.0)
    s.pause()
    s.resume()
    assert s.state == "answer"  # a pause at the answer keeps the stimuli
    s.press("second")
    assert s.position == 1
    s.close()


def test_view_never_names_the_condition(tmp_path: Path) -> None:
    s = Session(load_study("paper-study1").with_repetitions(1), "P01", tmp_path)
    seen = [s.view()]
    s.press("start")
    t = 0.0
    for _ in range(s.study.n_trials):
        seen.append(s.view())
        t = stroke(s, t, 20.0)
        seen.append(s.view())
        t = stroke(s, t, 20.0)
        seen.append(s.view())
        s.press("first")
    seen.append(s.view())
    text = json.dumps(seen)
    for word in ("mu_s", "mu0", "mu1", "string", "0.2", "0.4", "0.6", "0.8", "standard", "block"):
        assert word not in text, word
    assert s.state == "done"
    side = data.read_sidecar(tmp_path / "P01.json")
    assert side["end_time"] is not None and side["study"] == "paper-study1"
    s.close()


def test_resume_continues_after_the_last_complete_trial(tmp_path: Path) -> None:
    study = load_study("paper-study1").with_repetitions(1)
    s = Session(study, "P05", tmp_path)
    s.press("start")
    t = 0.0
    for _ in range(3):
        t = stroke(s, t, 20.0)
        t = stroke(s, t, 20.0)
        s.press("first")
    s.close()
    # a crash in the middle of writing the fourth row
    with (tmp_path / "P05.csv").open("a") as f:
        f.write("P05,paper-study1,2afc,4,1,mu0")
    again = Session(study, "P05", tmp_path)
    assert again.position == 3
    assert again.schedule == s.schedule
    assert again.view()["trial"] == 4
    again.press("start")
    t = stroke(again, t, 20.0)
    stroke(again, t, 20.0)
    again.press("second")
    again.close()
    rows = data.read_trials([tmp_path / "P05.csv"])
    assert [r["trial"] for r in rows] == [1, 2, 3, 4]
    assert len(data.read_sidecar(tmp_path / "P05.json")["resumed"]) == 1


def test_resume_refuses_another_study_or_seed(tmp_path: Path) -> None:
    Session(load_study("paper-study1"), "P01", tmp_path, seed=3).close()
    with pytest.raises(data.DataError, match="belongs to study 'paper-study1'"):
        Session(load_study("paper-study2"), "P01", tmp_path)
    with pytest.raises(data.DataError, match="keeps its seed"):
        Session(load_study("paper-study1"), "P01", tmp_path, seed=4)


def test_bad_participant_ids_are_refused(tmp_path: Path) -> None:
    from stiction.errors import StictionError

    for bad in ("", "../x", "a/b", ".hidden", "x" * 65):
        with pytest.raises(StictionError, match="participant ID"):
            Session(load_study("paper-study1"), bad, tmp_path)


@pytest.mark.parametrize(
    ("data", "words"),
    [
        ("[" * 3000 + "]" * 3000, "recursion"),  # fits the 4 KiB frame; the decoder recursed
        ("[1, 2]", "expected a JSON object"),
        ("not json", "Expecting value"),
    ],
)
def test_a_page_message_that_is_not_a_press_is_refused_in_words(data: str, words: str) -> None:
    from typing import Any, cast

    from stiction.experiment.live import LiveRunner

    runner = LiveRunner(cast(Any, None), "ipc:///nonexistent/p", "ipc:///nonexistent/c")
    refused = runner.press(data)
    assert refused is not None and words in refused


def _header() -> bytes:
    from stiction.experiment.data import COLUMNS

    return (",".join(COLUMNS) + "\n").encode()


_HEADER = _header()


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b"\xbc\xff\x00\rab\n", "not valid CSV"),  # was a UnicodeDecodeError traceback
        (_HEADER + b"p01\rx,1\n", "not valid CSV"),  # a stray CR: was a csv.Error traceback
    ],
)
def test_a_damaged_participant_file_is_one_data_error(
    tmp_path: Path, content: bytes, words: str
) -> None:
    from stiction.experiment.data import DataError, completed

    path = tmp_path / "p01.csv"
    path.write_bytes(content)
    with pytest.raises(DataError, match=words):
        completed(path)


@pytest.mark.parametrize("content", [b"[" * 100_000, b"\xbc\xff", b"[1, 2]"])
def test_a_damaged_sidecar_is_one_data_error(tmp_path: Path, content: bytes) -> None:
    """JSON nested 100,000 deep was a RecursionError traceback on resume."""
    from stiction.experiment.data import DataError, read_sidecar

    path = tmp_path / "p01.json"
    path.write_bytes(content)
    with pytest.raises(DataError, match="sidecar"):
        read_sidecar(path)


def test_a_fifo_in_place_of_a_participants_csv_is_an_error_not_a_hang(tmp_path: Path) -> None:
    """data.repair read the file with read_bytes before the checked reader saw it:
    a FIFO put in its place blocked a resumed session for good."""
    import os

    from stiction.experiment.data import DataError

    fifo = tmp_path / "P09.csv"
    os.mkfifo(fifo)
    with pytest.raises(DataError, match="not a regular file"):
        data.completed(fifo)


def test_repair_cuts_a_row_a_crash_left_half_written(tmp_path: Path) -> None:
    path = tmp_path / "P10.csv"
    path.write_bytes(b"a,b\n1,2\n3,")
    data.repair(path)
    assert path.read_bytes() == b"a,b\n1,2\n"
