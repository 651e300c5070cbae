"""Both paper studies end to end: simulated participants stroke the synthetic pen through
the real daemon (virtual clock), answer through the session's buttons, and the data
carry the observer's known truth.

The recovery checks run the analysis (stiction.experiment.analysis) on what the
simulated participants answered.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import pytest

from stiction.experiment import analysis
from stiction.experiment.data import read_trials
from stiction.experiment.observer import (
    ObserverParams,
    logistic_truth,
    true_curve,
    true_stevens,
)
from stiction.experiment.simulate import simulate_study
from stiction.experiment.study import Study, load_study

PARTICIPANTS = 5  # the analysis bootstraps participants: fewer make its intervals too narrow
OBSERVER = ObserverParams()


@pytest.fixture(scope="module")
def study1(tmp_path_factory: pytest.TempPathFactory) -> tuple[Study, list[Path]]:
    study = load_study("paper-study1").with_repetitions(3)
    out = tmp_path_factory.mktemp("study1")
    return study, simulate_study(study, out, PARTICIPANTS, seed=11, params=OBSERVER)


@pytest.fixture(scope="module")
def study2(tmp_path_factory: pytest.TempPathFactory) -> tuple[Study, list[Path]]:
    study = load_study("paper-study2").with_repetitions(2)
    out = tmp_path_factory.mktemp("study2")
    return study, simulate_study(study, out, PARTICIPANTS, seed=12, params=OBSERVER)


def _truth1(study: Study, string: bool) -> tuple[float, float, dict[float, float]]:
    curve = true_curve(
        OBSERVER, study.comparison_mu_s, study.standard_mu_s, study.params, study.display,
        study.travel_px, string,
    )  # fmt: skip
    pse, jnd = logistic_truth(curve)  # what the paper's logistic fit converges to
    return pse, jnd, curve


def test_study1_data_follow_the_observer(study1: tuple[Study, list[Path]]) -> None:
    study, paths = study1
    rows = read_trials(paths)
    assert len(rows) == PARTICIPANTS * study.n_trials
    chosen: dict[tuple[int, float], list[int]] = defaultdict(list)
    for r in rows:
        chosen[(r["string"], r["comparison_mu_s"])].append(r["chose_comparison"])
    for string in (1, 0):
        _, _, curve = _truth1(study, bool(string))
        observed = {mu: sum(v) / len(v) for (s, mu), v in chosen.items() if s == string}
        # rises with mu_s: the stickiest third is chosen more than the least sticky third
        # (by far with the string; the observer feels the no-string condition noisily)
        low = (observed[0.0] + observed[0.2]) / 2
        high = (observed[0.8] + observed[1.0]) / 2
        assert high > low + (0.25 if string else 0.0), observed
        # and each proportion is within 4 binomial SEs of what the observer's truth predicts
        n = len(chosen[(string, 0.0)])
        for mu, p in curve.items():
            se = math.sqrt(max(p * (1 - p), 0.05) / n)
            assert abs(observed[mu] - p) < 4 * se, (string, mu, observed[mu], p)
    strings = {r["string"]: r["max_string_length_px"] for r in rows}
    assert strings[0] is None and strings[1] is not None  # no string, none shown


def test_study2_ratios_follow_the_observer(study2: tuple[Study, list[Path]]) -> None:
    study, paths = study2
    rows = read_trials(paths)
    assert len(rows) == PARTICIPANTS * study.n_trials
    _, _, mean = true_stevens(
        OBSERVER, study.comparison_mu_s, study.standard_mu_s, study.params, study.display,
        study.travel_px,
    )  # fmt: skip
    ratios: dict[float, list[float]] = defaultdict(list)
    for r in rows:
        ratios[r["comparison_mu_s"]].append(r["ratio"])
        steps = [float(s) for s in r["adjustments"].split()]
        assert r["ratio"] == pytest.approx(1.0 + sum(steps), abs=1e-9)
    observed = {mu: sum(v) / len(v) for mu, v in ratios.items()}
    assert observed[1.0] > observed[0.4] + 0.1
    for mu, m in mean.items():
        assert abs(observed[mu] - m) < 0.08, (mu, observed[mu], m)


def _by_string(results: list[dict], string: int) -> dict:
    for r in results:
        if int(r.get("string", -1)) == string:
            return r
    raise AssertionError(f"no result for string={string} in {results}")


def test_analysis_recovers_pse_and_jnd(study1: tuple[Study, list[Path]]) -> None:
    study, paths = study1
    results = analysis.analyze(paths)
    for string in (1, 0):
        pse, jnd, _ = _truth1(study, bool(string))
        r = _by_string(results, string)
        lo, hi = r["pse_ci"]
        assert lo <= pse <= hi, (string, pse, r)
        lo, hi = r["jnd_ci"]
        assert lo <= jnd <= hi, (string, jnd, r)


def test_analysis_recovers_stevens_law(study2: tuple[Study, list[Path]]) -> None:
    study, paths = study2
    k, beta, _ = true_stevens(
        OBSERVER, study.comparison_mu_s, study.standard_mu_s, study.params, study.display,
        study.travel_px,
    )  # fmt: skip
    (r,) = analysis.analyze(paths)
    for name, truth in (("k", k), ("beta", beta)):
        lo, hi = _interval(r, name)
        assert lo <= truth <= hi, (name, truth, r["stevens"])
    assert r["anova"]["p"] < 0.05


def _interval(result: dict, name: str) -> tuple[float, float]:
    """The reported 95% interval: `<name>_ci`, else the estimate +- 1.96 standard errors."""
    for where in (result, result["stevens"]):
        if f"{name}_ci" in where:
            lo, hi = where[f"{name}_ci"]
            return float(lo), float(hi)
    s = result["stevens"]
    return s[name] - 1.96 * s[f"{name}_se"], s[name] + 1.96 * s[f"{name}_se"]
