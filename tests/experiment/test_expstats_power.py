"""Power's pieces: the shared Bayesian estimator, trials needed, the cheapest design."""

from __future__ import annotations

import numpy as np
import pytest

from stiction.experiment import power


def test_bayes_estimate_of_counts_is_questplus_posterior_mean() -> None:
    # Constant stimuli is scored with QUEST+'s own estimator: the posterior from
    # the same trials, fed one by one to questplus, must give the same JND.
    observer = power.Observer(pse=0.3, jnd=0.12, guess=0.0, lapse=0.02)
    grid = np.round(np.linspace(0.0, 1.0, 26), 6)
    levels = np.array([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    rng = np.random.default_rng(3)
    q = power._quest(grid, observer, grid)
    k = np.zeros(len(levels))
    for _ in range(3):
        for j, x in enumerate(levels):
            yes = rng.random() < float(observer.p(np.array([x]))[0])
            q.update(stim={"intensity": x}, outcome={"response": "Yes" if yes else "No"})
            k[j] += yes
    theirs = power.Z75 * float(q.param_estimate["sd"])
    ours = power.bayes_jnd(levels, k, np.full(len(levels), 3.0), observer, grid)
    assert ours.shape == (1,)
    assert ours[0] == pytest.approx(theirs, rel=1e-6)


def test_trials_needed_is_where_the_curve_stays_below_the_precision() -> None:
    trials = [6, 12, 18, 24, 30]
    assert power._needed(trials, [0.2, 0.04, 0.06, 0.04, 0.03], 0.05) == 24
    assert power._needed(trials, [0.2, 0.1, 0.06, 0.07, 0.06], 0.05) is None
    assert power._needed(trials, [0.01] * 5, 0.05) == 6


def test_failed_fits_count_as_infinite_errors() -> None:
    estimates = np.array([0.1] * 94 + [np.nan] * 6)
    assert power._error_quantile(estimates, 0.1) == np.inf
    assert power._error_quantile(estimates[:97], 0.1) == 0.0


def test_more_trials_shrink_the_error_and_the_cheapest_design_is_found() -> None:
    observer = power.Observer(pse=0.2, jnd=0.1)
    rows = power.design_table(
        observer, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0], 0.03, [5, 20], [5, 20], 300, seed=2
    )
    err = {(r.participants, r.repetitions): r.jnd_error95 for r in rows}
    assert err[20, 20] < err[5, 20] < err[5, 5]
    assert err[20, 20] < err[20, 5] < err[5, 5]
    best = power.cheapest(rows)
    assert best is not None and best.meets
    total = best.participants * best.trials_per_participant
    assert all(total <= r.participants * r.trials_per_participant for r in rows if r.meets)


def test_participants_pse_spread_inflates_the_pooled_jnd_error() -> None:
    observer = power.Observer(pse=0.3, jnd=0.1)
    levels = np.array([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    same = power.constant_stimuli_error(observer, levels, 20, 20, 300, np.random.default_rng(1))
    spread = power.constant_stimuli_error(
        observer, levels, 20, 20, 300, np.random.default_rng(1), participant_pse_sd=0.1
    )
    assert spread > 2 * same
