"""Trace CSV in, state CSV out: the file side of `stiction simulate`.

A trace is what a device produced, one row per input sample; replaying it
through the same ContactSim the daemon uses, with the same tick schedule,
gives exactly what the live daemon would have shown. Mistakes in the file are
reported with the file name and line number, never as a traceback.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from stiction.errors import RecordingError
from stiction.sim.contact import ContactSim
from stiction.sim.state import ContactState
from stiction.userfiles import open_regular_text

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


MAX_TRACE_GAP_S = 600.0
"""Longest pause between two samples. A trace ticks every 1/rate from its first
sample to its last (docs/design/architecture.md), so a pause of 1e9 s would be
1e11 ticks; a pause longer than ten minutes is two sessions, to be split."""


MAX_TRACE_COORD_M = 1000.0
"""Largest |x| or |y| in a trace, in metres: a hundred times the largest active
area stiction accepts (10 m), so no device's trace comes near it. A trace
at 1e308 m made the string's tension overflow to inf in the output."""


EXAMPLES = Path(__file__).with_name("examples")
"""Traces shipped with the package (made by scripts/make-example-traces.sh)."""


def resolve_trace(name: str) -> Path:
    """A trace path, or ``example:NAME`` for one shipped with the package."""
    if name.startswith("example:"):
        path = EXAMPLES / f"{name[len('example:') :]}.csv"
        if not path.is_file():
            known = ", ".join(sorted(f"example:{p.stem}" for p in EXAMPLES.glob("*.csv")))
            raise RecordingError(f"no shipped trace {name!r}; shipped: {known or 'none'}")
        return path
    return Path(name)


def read_trace(path: str | Path) -> list[TraceSample]:
    """The whole trace in memory; `open_trace` streams it instead."""
    with open_trace(path) as samples:
        return list(samples)


class open_trace:
    """Context manager streaming a trace file's samples, so a trace of any length
    is read in constant memory. Errors name the file and line."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._f: TextIO | None = None

    def __enter__(self) -> Iterator[TraceSample]:
        p = self.path
        # a FIFO or /dev/zero would be read for ever: refused, checked on the open descriptor
        self._f = open_regular_text(p, RecordingError, "trace")
        return _decoding(iter_trace(self._f, str(p)), str(p))

    def __exit__(self, *exc: object) -> None:
        if self._f is not None:
            self._f.close()


def _decoding(samples: Iterator[TraceSample], name: str) -> Iterator[TraceSample]:
    try:
        yield from samples
    except UnicodeDecodeError:
        raise RecordingError(f"{name}: not a text CSV file") from None
    except OSError as exc:
        raise RecordingError(f"{name}: cannot read trace: {exc.strerror or exc}") from None


def parse_trace(f: TextIO, name: str = "<trace>") -> list[TraceSample]:
    return list(iter_trace(f, name))


def iter_trace(f: TextIO, name: str = "<trace>") -> Iterator[TraceSample]:
    """The samples of a trace, one at a time, each checked (finite, in time order,
    no pause over MAX_TRACE_GAP_S, contact 0 or 1)."""
    reader = _Rows(csv.reader(f), name)
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
    it, ix, iy, ic = col["t"], col["x"], col["y"], col["contact"]
    ip = col.get("pressure")
    last_t = -math.inf
    any_sample = False
    for row in reader:
        line = reader.line_num
        if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
            continue
        if len(row) < len(header):
            raise RecordingError(f"{name}:{line}: expected {len(header)} columns, got {len(row)}")
        t = _num(row[it], "t", name, line)
        x = _coord(_num(row[ix], "x", name, line), "x", name, line)
        y = _coord(_num(row[iy], "y", name, line), "y", name, line)
        c = row[ic].strip()
        if c not in ("0", "1"):
            raise RecordingError(
                f"{name}:{line}: contact must be 0 (not touching) or 1 (touching), got {c!r}"
            )
        pressure = None
        if ip is not None and row[ip].strip():
            pressure = _num(row[ip], "pressure", name, line)
        if t < last_t:
            raise RecordingError(f"{name}:{line}: time {t!r} goes back (previous {last_t!r})")
        if last_t > -math.inf and t - last_t > MAX_TRACE_GAP_S:
            raise RecordingError(
                f"{name}:{line}: {t - last_t:g} s after the previous sample; a trace may "
                f"pause at most {MAX_TRACE_GAP_S:g} s (split it into two traces)"
            )
        last_t = t
        any_sample = True
        yield TraceSample(t, x, y, c == "1", pressure)
    if not any_sample:
        raise RecordingError(f"{name}: trace has a header but no samples")


class _Rows:
    """csv.reader whose own errors (a stray carriage return, a NUL) become RecordingErrors."""

    def __init__(self, reader: Any, name: str) -> None:
        self.reader = reader
        self.name = name

    @property
    def line_num(self) -> int:
        return int(self.reader.line_num)

    def __iter__(self) -> Iterator[list[str]]:
        return self

    def __next__(self) -> list[str]:
        try:
            return list(next(self.reader))
        except csv.Error as exc:
            raise RecordingError(f"{self.name}:{self.reader.line_num}: not CSV: {exc}") from None


def _num(text: str, what: str, name: str, line: int) -> float:
    try:
        v = float(text)
    except ValueError:
        raise RecordingError(f"{name}:{line}: {what} is not a number: {text.strip()!r}") from None
    if not math.isfinite(v):
        raise RecordingError(f"{name}:{line}: {what} must be finite, got {text.strip()!r}")
    return v


def _coord(v: float, what: str, name: str, line: int) -> float:
    if abs(v) > MAX_TRACE_COORD_M:
        raise RecordingError(
            f"{name}:{line}: {what} = {v:g} m is off any tablet; a trace is in metres, "
            f"at most {MAX_TRACE_COORD_M:g} from the origin"
        )
    return v


def tick_batches(
    samples: Iterable[TraceSample], rate: float
) -> Iterator[tuple[float, list[TraceSample]]]:
    """(tick time, samples since the previous tick): ticks every 1/rate from the
    first sample to the last. Reads `samples` lazily, one tick ahead at most."""
    it = iter(samples)
    nxt = next(it, None)
    if nxt is None:
        return
    t0 = nxt.t
    dt = 1.0 / rate
    tick = 0
    last_t = t0
    while True:
        t = t0 + tick * dt
        batch: list[TraceSample] = []
        while nxt is not None and nxt.t <= t + _SNAP:
            s = nxt
            if s.t > t:
                s = TraceSample(t, s.x, s.y, s.tip, s.pressure)
            batch.append(s)
            last_t = nxt.t
            nxt = next(it, None)
        # No tick after the last sample (architecture.md): once the samples are
        # exhausted, a tick past the last one ends the run, as before streaming.
        if nxt is None and t > last_t + _SNAP:
            break
        yield t, batch
        tick += 1


def simulate(
    samples: Iterable[TraceSample],
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
