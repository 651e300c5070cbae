"""Every input the fuzzer ever crashed a parser with, replayed: only an answer or a StictionError.

`make fuzz` (fuzz/run.py) writes crashing inputs to tests/regressions/TARGET/;
once the bug is fixed they stay here, so it cannot come back.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "fuzz"))
import targets  # noqa: E402

CASES = sorted(p for p in (HERE / "regressions").glob("*/*") if p.is_file())


def test_every_target_has_a_folder_and_every_folder_a_target() -> None:
    folders = {p.name for p in (HERE / "regressions").iterdir() if p.is_dir()}
    assert folders <= set(targets.TARGETS)


@pytest.mark.parametrize("case", CASES, ids=[f"{p.parent.name}/{p.name}" for p in CASES])
def test_a_saved_crash_is_now_an_answer(case: Path) -> None:
    targets.run_one(case.parent.name, case.read_bytes())


@pytest.mark.parametrize("name", sorted(targets.TARGETS))
def test_every_target_runs_on_empty_and_simple_input(name: str) -> None:
    for data in (b"", b"\x00", b"x" * 100):
        targets.run_one(name, data)
