"""The analyses of the paper's two user studies, from per-trial CSV files.

`analyze(paths)` returns one dict per (study, string condition):

* 2AFC (study 1): per comparison mu_s the proportion of "comparison more
  frictional" and its standard error across participants; the paper's
  logistic fitted by maximum likelihood to the pooled answers and to each
  participant's, and a fit with free guess and lapse rates; PSE, JND, A, B
  with percentile-bootstrap 95% intervals (pooled: participants resampled
  with replacement, then their trials within each level; one participant:
  trials resampled within each level).
* ratio (study 2): the mean ratio per mu_s (participant means first) and its
  standard error; Shapiro-Wilk per level, Mauchly's sphericity test and the
  one-way repeated-measures ANOVA with a Greenhouse-Geisser correction where
  sphericity is rejected (pingouin); Tukey HSD post-hoc comparisons; Stevens'
  power function phi = k mu_s^beta by least squares on the level means, with
  bootstrap intervals resampled in the same two stages.

Every number in the dicts is a plain float/int/str so that `--json` prints
them as they are and the report quotes them.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from stiction.experiment import psychometric as ps
from stiction.experiment.trials import AnalysisError, Trial, read_trials

DEFAULT_BOOTSTRAP = 1000
ALPHA = 0.05


def _ci(values: np.ndarray) -> list[float]:
    """Percentile interval of the non-NaN values; infinities stay (no interpolation)."""
    kept = values[~np.isnan(values)]
    if kept.size == 0:
        return [math.nan, math.nan]
    lo, hi = np.percentile(kept, [100 * ALPHA / 2, 100 * (1 - ALPHA / 2)], method="inverted_cdf")
    return [float(lo), float(hi)]


def _jnd_ci(a_ci: list[float]) -> list[float]:
    """The JND interval from A's: JND = ln(3)/A falls as A rises, for A > 0.

    A percentile interval carries over through a monotone map, but ln(3)/A is
    not monotone across A = 0: where A's interval reaches 0 or below (a flat
    or falling curve is plausible) the JND has no upper bound (inf, null in
    JSON), and a resample that was perfectly separated (A = inf) puts the
    lower bound at 0.
    """
    lo, hi = a_ci
    if math.isnan(lo) or math.isnan(hi) or hi <= 0:
        return [math.nan, math.nan]
    return [ps.LN3 / hi if hi < math.inf else 0.0, ps.LN3 / lo if lo > 0 else math.inf]


def _params(
    a: np.ndarray, b: np.ndarray, point: tuple[float, float], ok: np.ndarray
) -> dict[str, Any]:
    """Point estimates and percentile intervals of A, B, PSE and JND.

    Resamples with separated answers count as infinitely steep in A's and the
    JND's intervals and are left out of the PSE's (their PSE is unknown).
    """
    a_kept = np.where(ok | np.isinf(a), a, np.nan)
    b_ok = np.where(ok, b, np.nan)
    pa, pb = point
    a_ci = _ci(a_kept)
    return {
        "a": pa,
        "b": pb,
        "pse": pb,
        # No JND for a curve that does not rise (A <= 0) or has no finite fit.
        "jnd": ps.LN3 / pa if math.isfinite(pa) and pa > 0 else math.nan,
        "a_ci": a_ci,
        "b_ci": _ci(b_ok),
        "pse_ci": _ci(b_ok),
        "jnd_ci": _jnd_ci(a_ci),
    }


def _guess_lapse_params(
    fit: ps.Fit, boot: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
) -> dict[str, Any]:
    """The guess/lapse fit's estimates and the intervals of its (grid) bootstrap."""
    a, b, g, lam, ok = boot
    out = _params(a, b, (fit.a, fit.b), ok)
    out.update(
        guess=fit.guess,
        lapse=fit.lapse,
        guess_ci=_ci(np.where(ok, g, np.nan)),
        lapse_ci=_ci(np.where(ok, lam, np.nan)),
    )
    return out


def _matrix(trials: list[Trial]) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    """Participants, levels, and per participant x level counts of "comparison" and trials."""
    people = sorted({t.participant for t in trials})
    levels = np.array(sorted({t.comparison_mu_s for t in trials}))
    k = np.zeros((len(people), len(levels)))
    n = np.zeros((len(people), len(levels)))
    row = {p: i for i, p in enumerate(people)}
    col = {float(v): j for j, v in enumerate(levels)}
    for t in trials:
        i, j = row[t.participant], col[t.comparison_mu_s]
        k[i, j] += t.chose_comparison or 0
        n[i, j] += 1
    return people, levels, k, n


def _fit_both(levels: np.ndarray, k: np.ndarray, n: np.ndarray) -> tuple[ps.Fit, ps.Fit]:
    mask = n > 0
    x, kk, nn = levels[mask], k[mask], n[mask]
    return ps.fit_logistic(x, kk, nn), ps.fit_guess_lapse(x, kk, nn)


def _study1(
    study: str, string: int, trials: list[Trial], rng: np.random.Generator, boots: int
) -> dict[str, Any]:
    people, levels, k, n = _matrix(trials)
    if len(levels) < 3:
        raise AnalysisError(
            f"study {study!r}, string {string}: {len(levels)} comparison level(s); "
            "a psychometric fit needs at least 3"
        )
    with np.errstate(invalid="ignore", divide="ignore"):
        props = k / n  # NaN where a participant has no trial at a level
    counted = np.isfinite(props).sum(axis=0)
    se = np.array(
        [
            float(np.nanstd(props[:, j], ddof=1) / math.sqrt(counted[j]))
            if counted[j] > 1
            else math.nan
            for j in range(len(levels))
        ]
    )
    pooled_k, pooled_n = k.sum(axis=0), n.sum(axis=0)
    paper, free = _fit_both(levels, pooled_k, pooled_n)

    # Bootstrap of the pooled fit, in two stages (Davison & Hinkley 1997,
    # "Bootstrap Methods and their Application", section 3.8): resample
    # participants with replacement, then each drawn participant's trials within
    # each level. Participants alone would give 10 distinct resamples for 3
    # people, and intervals far too narrow; both stages err on the wide side.
    pick = rng.integers(0, len(people), size=(boots, len(people)))
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(n > 0, k / np.where(n > 0, n, 1.0), 0.0)
    bn = n[pick].sum(axis=1)
    bk = rng.binomial(n[pick].astype(int), rate[pick]).sum(axis=1).astype(float)
    resample = (
        "participants, then trials within each level"
        if len(people) > 1
        else "trials within each level"
    )
    # A resample may miss a level entirely (n = 0): it then adds nothing to the likelihood.
    ba, bb, bok = ps.fit_fixed(levels, bk, bn)
    ga, gb, gg, gl, gok = ps.fit_guess_lapse_many(levels, bk, bn)

    pooled = _params(ba, bb, (paper.a, paper.b), bok)
    guess_lapse = _guess_lapse_params(free, (ga, gb, gg, gl, gok))

    per_participant = []
    for i, who in enumerate(people):
        mask = n[i] > 0
        x, ki, ni = levels[mask], k[i][mask], n[i][mask]
        fit = ps.fit_logistic(x, ki, ni)
        pbk = rng.binomial(ni.astype(int), ki / ni, size=(boots, len(x)))
        pa, pb, pok = ps.fit_fixed(x, pbk, ni)
        entry = {"participant": who, "trials": int(ni.sum()), "converged": fit.converged}
        entry.update(_params(pa, pb, (fit.a, fit.b), pok))
        entry["bootstrap_failed"] = int((~pok).sum())
        own = ps.fit_guess_lapse(x, ki, ni)
        entry["guess_lapse"] = _guess_lapse_params(own, ps.fit_guess_lapse_many(x, pbk, ni))
        per_participant.append(entry)

    out: dict[str, Any] = {
        "study": study,
        "method": "2afc",
        "string": string,
        "participants": len(people),
        "trials": int(n.sum()),
        "levels": [float(v) for v in levels],
        "proportion": [float(v) for v in pooled_k / pooled_n],
        "proportion_mean": [float(v) for v in np.nanmean(props, axis=0)],
        "proportion_se": [float(v) for v in se],
        "converged": paper.converged,
    }
    out.update(pooled)
    out["bootstrap"] = {
        "n": boots,
        "resample": resample,
        "failed": int((~bok).sum()),
        "failed_guess_lapse": int((~gok).sum()),
    }
    out["guess_lapse"] = guess_lapse
    out["per_participant"] = per_participant
    return out


def _stevens_bootstrap(
    x: np.ndarray,
    trials: np.ndarray,
    start: tuple[float, float],
    rng: np.random.Generator,
    boots: int,
) -> tuple[np.ndarray, np.ndarray]:
    """k and beta refitted to resampled level means.

    `trials[i][j]` holds participant i's ratios at level j. Two stages, as for
    study 1: participants with replacement, then each one's trials per level.
    """
    from scipy.optimize import curve_fit

    def power_law(x: np.ndarray, k: float, beta: float) -> np.ndarray:
        return np.asarray(k * np.power(x, beta))

    people, levels = trials.shape
    cell_means = np.empty((boots, people, levels))
    for i in range(people):
        for j in range(levels):
            values = np.asarray(trials[i, j], dtype=float)
            draw = rng.integers(0, len(values), size=(boots, len(values)))
            cell_means[:, i, j] = values[draw].mean(axis=1)
    pick = rng.integers(0, people, size=(boots, people))
    level_means = np.take_along_axis(cell_means, pick[:, :, None], axis=1).mean(axis=1)
    ks, betas = np.full(boots, np.nan), np.full(boots, np.nan)
    for b in range(boots):
        # A resample that does not fit stays NaN and is left out of the percentiles.
        with contextlib.suppress(RuntimeError, ValueError):
            (ks[b], betas[b]), _ = curve_fit(power_law, x, level_means[b], p0=start)
    return ks, betas


def _study2(
    study: str, string: int, trials: list[Trial], rng: np.random.Generator, boots: int
) -> dict[str, Any]:
    import pandas as pd
    import pingouin as pg
    from scipy.optimize import curve_fit

    frame = pd.DataFrame(
        {
            "participant": [t.participant for t in trials],
            "mu_s": [t.comparison_mu_s for t in trials],
            "ratio": [t.ratio for t in trials],
        }
    )
    # Each participant's mean per level is the unit of the repeated-measures design.
    means = frame.groupby(["participant", "mu_s"], as_index=False)["ratio"].mean()
    levels = sorted(means["mu_s"].unique())
    people = sorted(means["participant"].unique())
    complete = means.groupby("participant")["mu_s"].nunique() == len(levels)
    if not complete.all():
        gaps = ", ".join(str(p) for p in complete[~complete].index)
        raise AnalysisError(
            f"study {study!r}: participant(s) {gaps} lack some mu_s level; "
            "the repeated-measures ANOVA needs every level from everyone"
        )
    if len(people) < 3 or len(levels) < 3:
        raise AnalysisError(
            f"study {study!r}: {len(people)} participant(s) and {len(levels)} level(s); "
            "the ANOVA and Mauchly's test need at least 3 of each"
        )
    by_level = means.groupby("mu_s")["ratio"]
    mean = by_level.mean().to_numpy()
    se = (by_level.std(ddof=1) / np.sqrt(by_level.count())).to_numpy()

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pingouin's FutureWarnings about pandas
        normal = pg.normality(means, dv="ratio", group="mu_s", method="shapiro")
        spher = pg.sphericity(means, dv="ratio", within="mu_s", subject="participant")
        aov = pg.rm_anova(
            means, dv="ratio", within="mu_s", subject="participant", correction=True
        ).iloc[0]
        tukey = pg.pairwise_tukey(means, dv="ratio", between="mu_s")

    spherical = bool(spher.spher)
    eps = float(aov["eps"])
    df1, df2 = float(aov["ddof1"]), float(aov["ddof2"])
    anova = {
        "f": float(aov["F"]),
        "df1": df1 if spherical else df1 * eps,
        "df2": df2 if spherical else df2 * eps,
        "p": float(aov["p_unc"]) if spherical else float(aov["p_GG_corr"]),
        "correction": None if spherical else "greenhouse-geisser",
        "p_uncorrected": float(aov["p_unc"]),
        "p_gg": float(aov["p_GG_corr"]),
        "eps_gg": eps,
        "eta2_generalized": float(aov["ng2"]),
    }

    def power_law(x: np.ndarray, k: float, beta: float) -> np.ndarray:
        return np.asarray(k * np.power(x, beta))

    x = np.asarray(levels, dtype=float)
    try:
        (k, beta), cov = curve_fit(power_law, x, mean, p0=(1.0, 0.2))
        k_se, beta_se = (float(v) for v in np.sqrt(np.diag(cov)))
    except (RuntimeError, ValueError) as exc:
        raise AnalysisError(
            f"study {study!r}: Stevens' power function did not fit: {exc}"
        ) from None
    cells = np.empty((len(people), len(levels)), dtype=object)
    for (who, level), group in frame.groupby(["participant", "mu_s"])["ratio"]:
        cells[people.index(who), levels.index(level)] = group.to_numpy()
    boot_k, boot_beta = _stevens_bootstrap(x, cells, (float(k), float(beta)), rng, boots)
    return {
        "study": study,
        "method": "ratio",
        "string": string,
        "participants": len(people),
        "trials": len(trials),
        "levels": [float(v) for v in levels],
        "mean": [float(v) for v in mean],
        "se": [float(v) for v in se],
        "shapiro": [
            {"mu_s": float(lvl), "w": float(r["W"]), "p": float(r["pval"])}
            for lvl, r in normal.iterrows()
        ],
        "mauchly": {
            "w": float(spher.W),
            "chi2": float(spher.chi2),
            "dof": int(spher.dof),
            "p": float(spher.pval),
            "spherical": spherical,
        },
        "anova": anova,
        "tukey": [
            {
                "a": float(r["A"]),
                "b": float(r["B"]),
                "diff": float(r["diff"]),
                "se": float(r["se"]),
                "t": float(r["T"]),
                "p": float(r["p_tukey"]),
            }
            for _, r in tukey.iterrows()
        ],
        "stevens": {
            "k": float(k),
            "beta": float(beta),
            "k_se": k_se,
            "beta_se": beta_se,
            "k_ci": _ci(boot_k),
            "beta_ci": _ci(boot_beta),
            "bootstrap_failed": int(np.isnan(boot_k).sum()),
        },
    }


def analyze_trials(
    trials: list[Trial], seed: int = 0, bootstrap: int = DEFAULT_BOOTSTRAP
) -> list[dict[str, Any]]:
    """One result per (study, method, string condition), in that order."""
    if bootstrap < 1:
        raise AnalysisError(f"--bootstrap must be at least 1, got {bootstrap}")
    groups: dict[tuple[str, str, int], list[Trial]] = {}
    for t in trials:
        groups.setdefault((t.study, t.method, t.string), []).append(t)
    rng = np.random.default_rng(seed)
    results = []
    for (study, method, string), rows in sorted(groups.items()):
        if method == "2afc":
            results.append(_study1(study, string, rows, rng, bootstrap))
        else:
            results.append(_study2(study, string, rows, rng, bootstrap))
    return results


def analyze(
    paths: Iterable[str | Path], seed: int = 0, bootstrap: int = DEFAULT_BOOTSTRAP
) -> list[dict[str, Any]]:
    """Read the trial CSVs (files or directories of them) and analyse every study in them."""
    return analyze_trials(read_trials(paths), seed=seed, bootstrap=bootstrap)
