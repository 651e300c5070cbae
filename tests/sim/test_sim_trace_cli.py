"""`stiction trace` (recordings -> traces) and what `stiction simulate` refuses or warns about."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stiction import protocol
from stiction.errors import RecordingError
from stiction.sim.trace import MAX_TRACE_GAP_S, iter_trace, resolve_trace


def _run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "stiction", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize(
    ("source", "extra", "samples"),
    [
        ("hid/xp-pen-artist-10s.hid", (), 3587),
        ("evdev/wacom-cintiq-13hd-touch-pen.evemu", (), 79),
        ("evdev/wacom-intuos4-6x9.desc", ("evdev/wacom-intuos4-6x9.stylus-drag.events",), 361),
    ],
)
def test_trace_from_real_recordings_has_the_samples_the_daemon_would_get(
    hid_data: Path, tmp_path: Path, source: str, extra: tuple[str, ...], samples: int
) -> None:
    data = hid_data.parent
    out = tmp_path / "t.csv"
    done = _run("trace", str(data / source), *(str(data / e) for e in extra), "--out", str(out))
    assert done.returncode == 0, done.stderr
    rows = _rows(out)
    assert len(rows) == samples
    assert list(rows[0]) == ["t", "x", "y", "contact", "pressure"]
    assert any(r["contact"] == "1" for r in rows) and any(r["contact"] == "0" for r in rows)
    ts = [float(r["t"]) for r in rows]
    assert ts == sorted(ts)
    sim = _run("simulate", str(out), "--out", str(tmp_path / "o.csv"))
    assert sim.returncode == 0 and "warning" not in sim.stderr, sim.stderr


def test_trace_of_a_stiction_recording(tmp_path: Path) -> None:
    from stiction.clients.messages import parse_message
    from stiction.clients.recording import write

    messages, frames = [], []
    for i in range(20):
        contact = {
            "id": 7,
            "phase": "stick" if i < 15 else "hover",
            "touch_m": [0.01 * i, 0.02],
            "pointer_m": [0.0, 0.02],
            "touch_px": [10.0 * i, 20.0],
            "pointer_px": [0.0, 20.0],
            "tension": 0.0,
            "material": "m",
        }
        wire = {"v": protocol.SCHEMA_VERSION, "kind": "frame", "tick": i, "t": i / 100}
        wire |= {"t_input": None, "device": "pen", "contacts": [contact]}
        topic, payload = protocol.frame_topic("pen"), protocol.encode(wire)
        messages.append((topic, payload, i / 100))
        frames.append(parse_message(topic, payload))
    rec = write(tmp_path / "s.npz", messages, frames, {})  # type: ignore[arg-type]
    out = tmp_path / "t.csv"
    done = _run("trace", str(rec), "--out", str(out))
    assert done.returncode == 0, done.stderr
    rows = _rows(out)
    assert [r["contact"] for r in rows] == ["1"] * 15 + ["0"] * 5
    assert float(rows[3]["x"]) == pytest.approx(0.03)
    wrong = _run("trace", str(rec), "--out", str(tmp_path / "u.csv"), "--contact", "1")
    assert wrong.returncode == 2 and "contact 1" in wrong.stderr


def test_trace_refuses_to_overwrite_without_force(tmp_path: Path) -> None:
    out = tmp_path / "t.csv"
    out.write_text("mine\n")
    done = _run("trace", "synthetic:stroke", "--out", str(out))
    assert done.returncode == 2 and "--force" in done.stderr
    assert out.read_text() == "mine\n"
    assert _run("trace", "synthetic:stroke", "--out", str(out), "--force").returncode == 0


def test_shipped_examples_simulate_and_unknown_ones_are_named() -> None:
    assert resolve_trace("example:stroke").is_file()
    with pytest.raises(RecordingError, match="example:circles"):
        resolve_trace("example:nope")


def test_a_contact_column_never_1_is_said_out_loud(tmp_path: Path) -> None:
    trace = tmp_path / "ids.csv"
    trace.write_text("t,x,y,contact\n0,0,0,0\n0.01,0.001,0,0\n0.02,0.002,0,0\n")
    done = _run("simulate", str(trace), "--out", str(tmp_path / "o.csv"))
    assert done.returncode == 0
    assert "no sample has contact = 1" in done.stderr


def test_a_scene_without_an_outside_material_warns_of_no_friction(tmp_path: Path) -> None:
    from stiction.scene.load import example_path

    done = _run(
        "simulate", "example:stroke", "--out", str(tmp_path / "o.csv"),
        "--scene", str(example_path("demo")),
    )  # fmt: skip
    assert done.returncode == 0 and "no friction" in done.stderr


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("0,0,0,1\n1e9,0,0,0\n", "pause at most"),
        ("0,0,0,1\nnan,0,0,0\n", "must be finite"),
        ("1,0,0,1\n0.5,0,0,0\n", "goes back"),
        ("0,0,0,2\n", "contact must be 0"),
    ],
)
def test_bad_traces_are_one_error_with_the_line(body: str, message: str) -> None:
    import io

    with pytest.raises(RecordingError, match=rf"t\.csv:\d+: .*{message}"):
        list(iter_trace(io.StringIO("t,x,y,contact\n" + body), "t.csv"))


def test_a_billion_second_gap_is_refused_quickly(tmp_path: Path) -> None:
    trace = tmp_path / "gap.csv"
    trace.write_text(f"t,x,y,contact\n0,0,0,1\n{MAX_TRACE_GAP_S * 1e7},0,0,0\n")
    done = _run("simulate", str(trace), "--out", str(tmp_path / "o.csv"))
    assert done.returncode == 2 and "gap.csv:3" in done.stderr


def test_a_long_trace_runs_in_constant_memory(tmp_path: Path) -> None:
    """300,000 rows: a reader holding the whole trace grows by tens of MB; streaming does not."""
    script = (
        "import resource, sys\n"
        "from stiction.cli import main\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "main(['simulate', sys.argv[1], '--out', sys.argv[2]])\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before)\n"
    )

    def peak(rows: int) -> int:
        trace = tmp_path / f"{rows}.csv"
        with trace.open("w") as f:
            f.write("t,x,y,contact\n")
            for i in range(rows):
                f.write(f"{i * 0.005:.3f},{(i % 1000) * 1e-4:.4f},0.01,{int(i % 3000 < 2000)}\n")
        done = subprocess.run(
            [sys.executable, "-c", script, str(trace), str(tmp_path / "o.csv")],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 0, done.stderr
        return int(done.stdout.split()[-1])

    small, large = peak(3_000), peak(300_000)
    assert large - small < 20_000  # KiB


@given(text=st.text(max_size=400))
def test_any_text_is_samples_or_one_recording_error(text: str) -> None:
    import io

    try:
        list(iter_trace(io.StringIO(text), "t.csv"))
    except RecordingError as exc:
        assert "\n" not in str(exc)


def test_ticks_end_at_the_last_sample_as_the_contract_says(tmp_path: Path) -> None:
    """architecture.md: ticks run from the first sample time up to the last sample time."""
    from stiction.sim.trace import TraceSample, tick_batches

    samples = [TraceSample(i * 0.005, 0.0, 0.0, True) for i in range(1000)]  # last at 4.995 s
    ticks = [t for t, _ in tick_batches(iter(samples), 100.0)]
    assert len(ticks) == 500 and ticks[-1] == pytest.approx(4.99)
    assert max(ticks) <= samples[-1].t
