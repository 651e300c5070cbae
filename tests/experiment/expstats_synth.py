"""Synthetic trial CSVs with a known truth, in the column layout of docs/experiments.md.

Study 1: answers drawn from a logistic psychometric function (with optional
guess and lapse rates) of the comparison's mu_s. Study 2: ratios drawn from a
Stevens power law k mu_s^beta times per-participant and per-trial noise.
Seeded, so each test sees the same data every run.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

COLUMNS = (  # noqa: SIM905 (one line of names reads like the CSV header)
    "participant study method trial block condition string standard_mu_s comparison_mu_s mu_k "
    "k c_l comparison_first chose_comparison ratio adjustments response_time_s stick_duration_s "
    "max_string_length_px max_pointer_touch_px stroke_speed_px_s"
).split()

STUDY1_LEVELS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
STUDY2_LEVELS = (0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)


def _row(**fields: object) -> dict[str, object]:
    base: dict[str, object] = {c: "" for c in COLUMNS}
    base.update(
        block=1,
        mu_k=0.1,
        k=0.1,
        c_l=2000,
        comparison_first=0,
        response_time_s=1.5,
        stick_duration_s=0.2,
        max_string_length_px=10.0,
        max_pointer_touch_px=12.0,
        stroke_speed_px_s=300.0,
    )
    base.update(fields)
    return base


def write_rows(path: Path, rows: list[dict[str, object]]) -> Path:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    return path


def study1(
    folder: Path,
    pse: float,
    jnd: float,
    participants: int = 10,
    reps: int = 10,
    seed: int = 1,
    guess: float = 0.0,
    lapse: float = 0.0,
    levels: tuple[float, ...] = STUDY1_LEVELS,
    strings: tuple[int, ...] = (0, 1),
    pse_sd: float = 0.0,
) -> list[Path]:
    """One CSV per participant; `pse_sd` spreads the participants' PSEs around `pse`."""
    rng = np.random.default_rng(seed)
    a = math.log(3) / jnd
    paths = []
    for i in range(participants):
        own = pse + rng.normal(0, pse_sd) if pse_sd else pse
        rows = []
        trial = 0
        for s in strings:
            for mu in levels:
                for _ in range(reps):
                    p = guess + (1 - guess - lapse) / (1 + math.exp(-a * (mu - own)))
                    trial += 1
                    rows.append(
                        _row(
                            participant=f"p{i:02d}",
                            study="paper-study1",
                            method="2afc",
                            trial=trial,
                            condition=f"mu{mu}-{'string' if s else 'nostring'}",
                            string=s,
                            standard_mu_s=0.0,
                            comparison_mu_s=mu,
                            chose_comparison=int(rng.random() < p),
                        )
                    )
        paths.append(write_rows(folder / f"p{i:02d}.csv", rows))
    return paths


def study2(
    folder: Path,
    k: float,
    beta: float,
    participants: int = 10,
    reps: int = 5,
    seed: int = 2,
    person_sd: float = 0.05,
    trial_sd: float = 0.05,
    slope_sd: float = 0.0,
) -> list[Path]:
    """`slope_sd` gives each participant their own linear trend in mu_s, which
    makes the variance of the differences between levels grow with their
    distance: a violation of sphericity."""
    rng = np.random.default_rng(seed)
    paths = []
    for i in range(participants):
        offset = rng.normal(0, person_sd)
        slope = rng.normal(0, slope_sd)
        rows = []
        trial = 0
        for mu in STUDY2_LEVELS:
            for _ in range(reps):
                trial += 1
                noise = offset + slope * (mu - 0.7) + rng.normal(0, trial_sd)
                ratio = max(0.05, k * mu**beta + noise)
                rows.append(
                    _row(
                        participant=f"q{i:02d}",
                        study="paper-study2",
                        method="ratio",
                        trial=trial,
                        condition=f"mu{mu}-string",
                        string=1,
                        standard_mu_s=0.7,
                        comparison_mu_s=mu,
                        ratio=round(ratio, 2),
                        adjustments="+0.10 -0.01",
                    )
                )
        paths.append(write_rows(folder / f"q{i:02d}.csv", rows))
    return paths
