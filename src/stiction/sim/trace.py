"""Trace CSV in, state CSV out: the file side of `stiction simulate`.

A trace is what a device produced, one row per input sample; replaying it
through the same ContactSim the daemon uses, with the same tick schedule,
gives exactly what the live daemon would have shown. Mistakes in the file are
reported with the file name and line number, never as a traceback.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from stiction.errors import RecordingError
from stiction.sim.contact import ContactSim
from stiction.sim.state import ContactState

TRACE_COLUMNS = ("t", "x", "y", "contact")
OUT_COLUMNS = (
    "t",
    "touch_x",
    "touch_y",
    "pointer_x",
    "pointer_y",
    "vx",
    "vy",
    "phase",
    "tension",
    "string_px",
)
_SNAP = 1e-9
"""Seconds: a sample this close to a tick counts as at the tick (tick times are sums of floats)."""


@dataclass(frozen=True, slots=True)
class TraceSample:
    t: float
    x: float
    y: float
    tip: bool
    pressure: float | None = None
    in_range: bool = False
    """A trace has no hover column: a row with contact 0 is out of range ("up")."""


def read_trace(path: str | Path) -> list[TraceSample]:
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as f:
            return parse_trace(f, str(p))
    except OSError as exc:
        raise RecordingError(f"{p}: cannot read trace: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise RecordingError(f"{p}: not a text CSV file") from None


def parse_trace(f: TextIO, name: str = "<trace>") -> list[TraceSample]:
    reader = csv.reader(f)
    header: list[str] | None = None
    for row in reader:
        if row and not row[0].lstrip().startswith("#"):
            header = [c.strip() for c in row]
            break
    if header is None:
        raise RecordingError(f"{name}: empty trace (expected a header t,x,y,contact)")
    missing = [c for c in TRACE_COLUMNS if c not in header]
    if missing:
        raise RecordingError(
            f"{name}:{reader.line_num}: header lacks {', '.join(missing)} "
            f"(expected t,x,y,contact[,pressure]), got {','.join(header)}"
        )
    col = {c: header.index(c) for c in header}
    ip = col.get("pressure")
    out: list[TraceSample] = []
    last_t = -math.inf
    for row in reader:
        line = reader.line_num
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        if len(row) < len(header):
            raise RecordingError(f"{name}:{line}: expected {len(header)} columns, got {len(row)}")
        t = _num(row[col["t"]], "t", name, line)
        x = _num(row[col["x"]], "x", name, line)
        y = _num(row[col["y"]], "y", name, line)
        c = row[col["contact"]].strip()
        if c not in ("0", "1"):
            raise RecordingError(f"{name}:{line}: contact must be 0 or 1, got {c!r}")
        pressure = None
        if ip is not None and row[ip].strip():
            pressure = _num(row[ip], "pressure", name, line)
        if t < last_t:
            raise RecordingError(f"{name}:{line}: time {t!r} goes back (previous {last_t!r})")
        last_t = t
        out.append(TraceSample(t, x, y, c == "1", pressure))
    if not out:
        raise RecordingError(f"{name}: trace has a header but no samples")
    return out


def _num(text: str, what: str, name: str, line: int) -> float:
    try:
        v = float(text)
    except ValueError:
        raise RecordingError(f"{name}:{line}: {what} is not a number: {text.strip()!r}") from None
    if not math.isfinite(v):
        raise RecordingError(f"{name}:{line}: {what} must be finite, got {text.strip()!r}")
    return v


def tick_batches(
    samples: Sequence[TraceSample], rate: float
) -> Iterator[tuple[float, list[TraceSample]]]:
    """(tick time, samples since the previous tick): ticks every 1/rate from the first sample."""
    t0 = samples[0].t
    t_end = samples[-1].t
    dt = 1.0 / rate
    i = 0
    n = len(samples)
    tick = 0
    while True:
        t = t0 + tick * dt
        if t > t_end + _SNAP:
            break
        batch: list[TraceSample] = []
        while i < n and samples[i].t <= t + _SNAP:
            s = samples[i]
            if s.t > t:
                s = TraceSample(t, s.x, s.y, s.tip, s.pressure)
            batch.append(s)
            i += 1
        yield t, batch
        tick += 1


def simulate(
    samples: Sequence[TraceSample],
    sim: ContactSim,
    load_gain: Callable[[float | None], float] | None = None,
    passthrough: bool = False,
) -> Iterator[ContactState]:
    """Run a trace through sim at sim.params.rate, yielding the state at every tick."""
    pressure: float | None = None
    for t, batch in tick_batches(samples, sim.params.rate):
        if batch and batch[-1].pressure is not None:
            pressure = batch[-1].pressure
        gain = load_gain(pressure) if load_gain is not None else 1.0
        st = sim.advance(t, batch, load_gain=gain)
        if passthrough and st.phase in ("stick", "slip"):
            st = ContactState(
                st.t, st.touch_x, st.touch_y, st.touch_x, st.touch_y, 0.0, 0.0,
                "slip", 0.0, 0.0, (0.0, 0.0),
            )  # fmt: skip
        yield st


def write_states(states: Iterator[ContactState], f: TextIO) -> int:
    w = csv.writer(f, lineterminator="\n")
    w.writerow(OUT_COLUMNS)
    n = 0
    for s in states:
        w.writerow(
            (
                repr(s.t), repr(s.touch_x), repr(s.touch_y), repr(s.pointer_x),
                repr(s.pointer_y), repr(s.vx), repr(s.vy), s.phase, repr(s.tension),
                repr(s.string_px),
            )
        )  # fmt: skip
        n += 1
    return n
