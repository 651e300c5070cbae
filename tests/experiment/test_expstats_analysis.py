"""`analysis.analyze` on synthetic data with a known truth; pingouin against statsmodels/scipy."""

from __future__ import annotations

import itertools
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from expstats_synth import study1, study2

from stiction.experiment import analysis
from stiction.experiment.report import jsonable


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, Any]]:
    d1 = tmp_path_factory.mktemp("s1")
    d2 = tmp_path_factory.mktemp("s2")
    study1(d1, pse=0.25, jnd=0.12, participants=10, reps=10, lapse=0.0, pse_sd=0.02)
    study2(d2, k=1.12, beta=0.204, participants=10, reps=5)
    return analysis.analyze([d1, d2], seed=4, bootstrap=300)


def _one(results: list[dict[str, Any]], method: str, string: int) -> dict[str, Any]:
    (r,) = [r for r in results if r["method"] == method and r["string"] == string]
    return r


@pytest.mark.parametrize("string", [0, 1])
def test_study1_intervals_hold_the_truth(results: list[dict[str, Any]], string: int) -> None:
    r = _one(results, "2afc", string)
    assert r["participants"] == 10 and r["trials"] == 600
    assert r["levels"] == [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    lo, hi = r["pse_ci"]
    assert lo < 0.25 < hi
    lo, hi = r["jnd_ci"]
    assert lo < 0.12 < hi
    assert r["jnd"] == pytest.approx(np.log(3) / r["a"])
    assert r["bootstrap"] == {
        "n": 300,
        "resample": "participants, then trials within each level",
        "failed": 0,
        "failed_guess_lapse": 0,
    }
    assert len(r["per_participant"]) == 10
    for p in r["per_participant"]:
        assert {"pse", "jnd", "pse_ci", "jnd_ci", "guess_lapse"} <= set(p)
        assert 0 <= p["guess_lapse"]["guess"] <= 0.5 and 0 <= p["guess_lapse"]["lapse"] <= 0.1
    # The pooled proportion and the mean of participants' proportions agree when
    # everyone has the same number of trials per level.
    assert r["proportion"] == pytest.approx(r["proportion_mean"])


def test_study1_rising_proportions_with_standard_errors(results: list[dict[str, Any]]) -> None:
    r = _one(results, "2afc", 1)
    assert r["proportion"][0] < 0.2 < 0.9 < r["proportion"][-1]
    assert all(0 <= se < 0.2 for se in r["proportion_se"])


def test_study2_recovers_stevens_law_and_finds_the_effect(results: list[dict[str, Any]]) -> None:
    r = _one(results, "ratio", 1)
    assert r["anova"]["df1"] == 6 and r["anova"]["df2"] == 54
    assert r["anova"]["p"] < 0.001
    st = r["stevens"]
    assert st["k"] == pytest.approx(1.12, abs=3 * st["k_se"] + 0.02)
    assert st["beta"] == pytest.approx(0.204, abs=3 * st["beta_se"] + 0.02)
    assert st["k_ci"][0] < 1.12 < st["k_ci"][1]
    assert st["beta_ci"][0] < 0.204 < st["beta_ci"][1]
    assert st["bootstrap_failed"] == 0
    assert len(r["tukey"]) == 21 and len(r["shapiro"]) == 7


def test_jnd_interval_follows_the_slope_interval() -> None:
    # ln(3)/A is decreasing for A > 0 and unbounded where A's interval reaches 0.
    assert analysis._jnd_ci([2.0, 4.0]) == pytest.approx([np.log(3) / 4, np.log(3) / 2])
    assert analysis._jnd_ci([-1.0, 4.0]) == [pytest.approx(np.log(3) / 4), np.inf]
    assert analysis._jnd_ci([2.0, np.inf]) == [0.0, pytest.approx(np.log(3) / 2)]
    assert all(np.isnan(analysis._jnd_ci([-3.0, -1.0])))


def test_separated_resamples_count_as_infinitely_steep(tmp_path: Path) -> None:
    # One participant with few trials: some resamples are a step between two
    # levels; they widen the slope interval to infinity instead of vanishing.
    study1(tmp_path, pse=0.3, jnd=0.03, participants=1, reps=3, strings=(1,), seed=5)
    (r,) = analysis.analyze([tmp_path], seed=1, bootstrap=200)
    assert r["bootstrap"]["failed"] > 0
    assert r["a_ci"][1] == np.inf and r["jnd_ci"][0] == 0.0


def test_seed_makes_the_bootstrap_repeatable(tmp_path: Path) -> None:
    study1(tmp_path, pse=0.3, jnd=0.1, participants=3, reps=4, strings=(1,))
    one = analysis.analyze([tmp_path], seed=9, bootstrap=50)
    two = analysis.analyze([tmp_path], seed=9, bootstrap=50)
    other = analysis.analyze([tmp_path], seed=10, bootstrap=50)
    # Compared as JSON: a participant without a finite fit has NaN, and NaN != NaN.
    assert json.dumps(jsonable(one)) == json.dumps(jsonable(two))
    assert one[0]["jnd_ci"] != other[0]["jnd_ci"]


def test_greenhouse_geisser_applies_where_sphericity_fails(tmp_path: Path) -> None:
    study2(tmp_path, k=1.1, beta=0.2, participants=12, reps=3, slope_sd=0.6, seed=4)
    (r,) = analysis.analyze([tmp_path], bootstrap=20)
    a = r["anova"]
    assert not r["mauchly"]["spherical"] and r["mauchly"]["p"] < 0.05
    assert a["correction"] == "greenhouse-geisser"
    assert a["p"] == a["p_gg"] and a["p"] > a["p_uncorrected"]
    assert (a["df1"], a["df2"]) == pytest.approx((6 * a["eps_gg"], 66 * a["eps_gg"]))


def _known_rm_data(seed: int = 6) -> Any:
    import pandas as pd

    rng = np.random.default_rng(seed)
    rows = []
    for p in range(12):
        offset = rng.normal(0, 0.2)
        for j, level in enumerate([0.4, 0.6, 0.8, 1.0]):
            # Unequal variances across levels, so that sphericity is in question.
            rows.append((f"p{p}", level, 1 + 0.1 * j + offset + rng.normal(0, 0.05 + 0.1 * j)))
    return pd.DataFrame(rows, columns=["participant", "mu_s", "ratio"])


def test_pingouin_anova_agrees_with_statsmodels() -> None:
    import pingouin as pg
    from statsmodels.stats.anova import AnovaRM

    data = _known_rm_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = pg.rm_anova(data, dv="ratio", within="mu_s", subject="participant").iloc[0]
    table = AnovaRM(data, depvar="ratio", subject="participant", within=["mu_s"]).fit().anova_table
    assert float(ours["F"]) == pytest.approx(float(table["F Value"].iloc[0]), rel=1e-9)
    assert float(ours["p_unc"]) == pytest.approx(float(table["Pr > F"].iloc[0]), rel=1e-6)
    assert (ours["ddof1"], ours["ddof2"]) == (table["Num DF"].iloc[0], table["Den DF"].iloc[0])


def test_pingouin_mauchly_and_greenhouse_geisser_agree_with_the_textbook_formulas() -> None:
    # Mauchly (1940) and Greenhouse & Geisser (1959) from the covariance of
    # orthonormal contrasts, with scipy's chi-squared: an independent computation.
    import pingouin as pg
    from scipy import linalg, stats

    data = _known_rm_data()
    wide = data.pivot(index="participant", columns="mu_s", values="ratio").to_numpy()
    n, k = wide.shape
    contrasts = linalg.null_space(np.ones((1, k)))  # k x (k-1), orthonormal
    s = np.cov(wide @ contrasts, rowvar=False)
    p = k - 1
    w = np.linalg.det(s) / (np.trace(s) / p) ** p
    f = (2 * p**2 + p + 2) / (6 * p * (n - 1))
    chi2 = -(1 - f) * (n - 1) * np.log(w)
    dof = p * (p + 1) / 2 - 1
    eps = np.trace(s) ** 2 / (p * np.trace(s @ s))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        spher = pg.sphericity(data, dv="ratio", within="mu_s", subject="participant")
        aov = pg.rm_anova(
            data, dv="ratio", within="mu_s", subject="participant", correction=True
        ).iloc[0]
    assert float(spher.W) == pytest.approx(w, rel=1e-6)
    assert float(spher.chi2) == pytest.approx(chi2, rel=1e-6)
    assert spher.dof == dof
    # pingouin's p adds the second-order term of Anderson's expansion, as R's
    # mauchly.test does; the first-order chi-squared p is within a few 1e-4.
    assert float(spher.pval) == pytest.approx(stats.chi2.sf(chi2, dof), abs=1e-3)
    assert float(aov["eps"]) == pytest.approx(eps, rel=1e-6)
    gg_p = stats.f.sf(aov["F"], eps * aov["ddof1"], eps * aov["ddof2"])
    assert float(aov["p_GG_corr"]) == pytest.approx(gg_p, rel=1e-6)


def test_pingouin_tukey_agrees_with_statsmodels() -> None:
    import pingouin as pg
    from statsmodels.stats.multicomp import pairwise_tukeyhsd

    data = _known_rm_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = pg.pairwise_tukey(data, dv="ratio", between="mu_s")
    theirs = pairwise_tukeyhsd(data["ratio"], data["mu_s"])
    pairs = list(itertools.combinations(sorted(data["mu_s"].unique()), 2))
    assert [(float(a), float(b)) for a, b in zip(ours["A"], ours["B"], strict=True)] == pairs
    # pingouin computes the studentized-range p-value itself, statsmodels from
    # its own tables/interpolation: equal to about three decimals.
    assert np.asarray(ours["p_tukey"], float) == pytest.approx(
        np.asarray(theirs.pvalues, float), abs=2e-3
    )
