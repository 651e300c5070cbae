"""Reading the per-trial CSV files of `stiction experiment run`/`simulate` for analysis.

The analysis reads only the columns it needs (docs/experiments.md, "Data"):
participant, study, method, string, comparison_mu_s, and chose_comparison
(2AFC) or ratio (ratio estimation). Every file and row is checked here, so
that a malformed file is one clear `AnalysisError` naming the file, line
and column -- never a traceback from deep inside pandas or scipy.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from stiction.errors import StictionError
from stiction.userfiles import read_regular_text

REQUIRED = ("participant", "study", "method", "string", "comparison_mu_s")
METHODS = ("2afc", "ratio")
MAX_BYTES = 64 << 20  # a study is thousands of rows; 64 MiB is far beyond one


class AnalysisError(StictionError):
    """Trial data that cannot be analysed; the message says which file and why."""


@dataclass(frozen=True)
class Trial:
    """The fields of one trial row that the analysis uses."""

    participant: str
    study: str
    method: str
    string: int
    comparison_mu_s: float
    chose_comparison: int | None  # 2afc
    ratio: float | None  # ratio estimation


def csv_paths(args: Iterable[str | Path]) -> list[Path]:
    """The CSV files named, with each directory standing for the *.csv files in it."""
    out: list[Path] = []
    for arg in args:
        p = Path(arg)
        if p.is_dir():
            found = sorted(q for q in p.glob("*.csv") if q.is_file())
            if not found:
                raise AnalysisError(f"{p}: no .csv trial files in this directory")
            out.extend(found)
        elif p.suffix == ".json" and p.exists():
            raise AnalysisError(
                f"{p}: a session sidecar, not trial data; name the .csv files or their directory"
            )
        elif p.exists():
            out.append(p)
        else:
            raise AnalysisError(f"{p}: no such file or directory")
    if not out:
        raise AnalysisError("no trial files given")
    return out


def _number(text: str, where: str, column: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise AnalysisError(f"{where}: {column} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise AnalysisError(f"{where}: {column} must be finite, got {text!r}")
    return value


def _flag(text: str, where: str, column: str) -> int:
    if text.strip() not in ("0", "1"):
        raise AnalysisError(f"{where}: {column} must be 0 or 1, got {text!r}")
    return int(text)


def _row(row: dict[str, str], where: str) -> Trial:
    method = row["method"].strip()
    if method not in METHODS:
        raise AnalysisError(f"{where}: method must be one of {', '.join(METHODS)}, got {method!r}")
    participant = row["participant"].strip()
    if not participant:
        raise AnalysisError(f"{where}: participant is empty")
    mu = _number(row["comparison_mu_s"], where, "comparison_mu_s")
    if mu < 0:
        raise AnalysisError(f"{where}: comparison_mu_s must not be negative, got {mu}")
    chose: int | None = None
    ratio: float | None = None
    if method == "2afc":
        if "chose_comparison" not in row or row["chose_comparison"] is None:
            raise AnalysisError(f"{where}: a 2afc trial needs the chose_comparison column")
        chose = _flag(row["chose_comparison"], where, "chose_comparison")
    else:
        if "ratio" not in row or row["ratio"] is None:
            raise AnalysisError(f"{where}: a ratio trial needs the ratio column")
        ratio = _number(row["ratio"], where, "ratio")
        if ratio <= 0:
            raise AnalysisError(f"{where}: ratio must be positive, got {ratio}")
    return Trial(
        participant=participant,
        study=row["study"].strip() or "unnamed",
        method=method,
        string=_flag(row["string"], where, "string"),
        comparison_mu_s=mu,
        chose_comparison=chose,
        ratio=ratio,
    )


def read_file(path: Path) -> list[Trial]:
    """The trials of one CSV file, checked row by row."""
    # A spreadsheet that saved the file may have put a byte-order mark first.
    text = read_regular_text(path, MAX_BYTES, AnalysisError, "trial CSV").removeprefix("\ufeff")
    reader = csv.DictReader(io.StringIO(text))
    try:
        header = reader.fieldnames or []
    except csv.Error as exc:  # binary junk fails already in the header row
        raise AnalysisError(f"{path}:{max(reader.line_num, 1)}: not valid CSV: {exc}") from None
    missing = [c for c in REQUIRED if c not in header]
    if not header:
        raise AnalysisError(f"{path}: empty file; expected a CSV header and trial rows")
    if missing:
        raise AnalysisError(
            f"{path}: not a trial CSV: missing column(s) {', '.join(missing)} "
            f"(docs/experiments.md, Data)"
        )
    trials = []
    try:
        for row in reader:
            where = f"{path}:{reader.line_num}"
            if None in row or any(v is None for v in row.values()):
                raise AnalysisError(
                    f"{where}: {len(header)} columns in the header, not in this row"
                )
            trials.append(_row(row, where))
    except csv.Error as exc:
        raise AnalysisError(f"{path}:{reader.line_num}: not valid CSV: {exc}") from None
    if not trials:
        raise AnalysisError(f"{path}: a header but no trial rows")
    return trials


def read_trials(paths: Iterable[str | Path]) -> list[Trial]:
    """All trials of the named files and directories."""
    out: list[Trial] = []
    for p in csv_paths(paths):
        out.extend(read_file(p))
    return out
