"""Per-participant data: one CSV row per trial, flushed to disk as it happens, and a sidecar.

A session can end at any moment (a crash, a closed laptop); the CSV is
appended to and fsync'ed after every trial, so at most the trial in
progress is lost, and `completed()` tells a resumed session where to go
on. A row cut short by a crash (no final newline) is dropped on resume.
The column order is a contract with the analysis (docs/experiments.md,
"Data").
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from stiction.errors import StictionError
from stiction.userfiles import open_regular, read_regular_text

MAX_TRIALS_BYTES = 64 << 20
"""One participant's trial CSV: thousands of rows; 64 MiB is far beyond one."""

COLUMNS = (
    "participant",
    "study",
    "method",
    "trial",
    "block",
    "condition",
    "string",
    "standard_mu_s",
    "comparison_mu_s",
    "mu_k",
    "k",
    "c_l",
    "comparison_first",
    "chose_comparison",
    "ratio",
    "adjustments",
    "response_time_s",
    "stick_duration_s",
    "max_string_length_px",
    "max_pointer_touch_px",
    "stroke_speed_px_s",
    "std_stick_duration_s",
    "std_max_string_length_px",
    "std_max_pointer_touch_px",
    "std_stroke_speed_px_s",
)
INT_COLUMNS = ("trial", "block", "string", "comparison_first", "chose_comparison")
TEXT_COLUMNS = ("participant", "study", "method", "condition", "adjustments")


class DataError(StictionError):
    """A data file that cannot be read or continued."""


def csv_path(out: Path, participant: str) -> Path:
    return out / f"{participant}.csv"


def sidecar_path(out: Path, participant: str) -> Path:
    return out / f"{participant}.json"


def _fmt(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


class TrialWriter:
    """Appends rows to a participant's CSV; each row is on disk when `write` returns."""

    def __init__(self, path: Path) -> None:
        self.path = path
        new = not path.exists() or path.stat().st_size == 0
        self._file = open(path, "a", newline="", encoding="utf-8")  # noqa: SIM115 (lives long)
        if new:
            self._emit(COLUMNS)

    def _emit(self, cells: Iterable[str]) -> None:
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(list(cells))
        self._file.write(buf.getvalue())
        self._file.flush()
        os.fsync(self._file.fileno())

    def write(self, row: Mapping[str, Any]) -> None:
        unknown = set(row) - set(COLUMNS)
        if unknown:
            raise ValueError(f"unknown columns {sorted(unknown)}")
        self._emit(_fmt(row.get(c)) for c in COLUMNS)

    def close(self) -> None:
        self._file.close()


def _convert(row: dict[str, str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, text in row.items():
        if key in TEXT_COLUMNS:
            out[key] = text
        elif text == "":
            out[key] = None
        elif key in INT_COLUMNS:
            out[key] = int(text)
        else:
            out[key] = float(text)
    return out


def repair(path: Path) -> None:
    """Cut a last row that a crash left without its newline (it is incomplete)."""
    if not path.exists():
        return
    # a regular file of bounded size, or a DataError: a FIFO put in its place blocked here
    with open_regular(path, MAX_TRIALS_BYTES, DataError, "trial CSV") as f:
        data = f.read(MAX_TRIALS_BYTES + 1)
    if data and not data.endswith(b"\n"):
        cut = data.rfind(b"\n") + 1
        with open(path, "r+b") as f:
            f.truncate(cut)


def read_trials(paths: Iterable[str | Path]) -> list[dict[str, Any]]:
    """Every complete row of the given CSVs (or of every CSV in a given folder), typed."""
    rows: list[dict[str, Any]] = []
    for p in paths:
        path = Path(p)
        files = sorted(path.glob("*.csv")) if path.is_dir() else [path]
        for f in files:
            # A participant's file is resumed from: read as a bounded regular file,
            # and a damaged one (binary, a stray NUL) is a DataError, not a
            # UnicodeDecodeError or csv.Error traceback in front of the participant.
            text = read_regular_text(f, MAX_TRIALS_BYTES, DataError, "trial CSV")
            if text and not text.endswith("\n"):
                text = text[: text.rfind("\n") + 1]
            reader = csv.DictReader(io.StringIO(text))
            try:
                header = tuple(reader.fieldnames or ())
                if header[: len(COLUMNS) - 4] != COLUMNS[: len(COLUMNS) - 4]:
                    raise DataError(f"{f}: not a stiction experiment CSV (unexpected header)")
                for n, row in enumerate(reader, start=2):
                    try:
                        rows.append(_convert(row))
                    except (ValueError, TypeError):
                        raise DataError(f"{f}:{n}: malformed row") from None
            except csv.Error as exc:
                raise DataError(f"{f}:{max(reader.line_num, 1)}: not valid CSV: {exc}") from None
    return rows


def completed(path: Path) -> int:
    """How many trials a participant's CSV holds (they are numbered 1..n in order)."""
    repair(path)
    if not path.exists():
        return 0
    rows = read_trials([path])
    for i, row in enumerate(rows, start=1):
        if row["trial"] != i:
            raise DataError(f"{path}: trial {row['trial']} where {i} was expected")
    return len(rows)


def write_sidecar(path: Path, info: Mapping[str, Any]) -> None:
    """Replace the sidecar atomically: a crash leaves the old one or the new one."""
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(info, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    with open(tmp, "rb") as f:
        os.fsync(f.fileno())
    os.replace(tmp, path)


def read_sidecar(path: Path) -> dict[str, Any]:
    try:
        text = read_regular_text(path, MAX_TRIALS_BYTES, DataError, "sidecar")
        data = json.loads(text)
    except (ValueError, RecursionError) as exc:  # RecursionError: JSON nested thousands deep
        raise DataError(f"{path}: cannot read the sidecar: {exc}") from None
    if not isinstance(data, dict):
        raise DataError(f"{path}: the sidecar is not a JSON object")
    return data
