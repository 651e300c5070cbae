"""The psychometric fits: against statsmodels and psignifit, and recovering a known observer."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from stiction.experiment import psychometric as ps

LEVELS = np.array([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])


def _draw(pse: float, jnd: float, n: int, seed: int, guess: float = 0.0, lapse: float = 0.0):
    rng = np.random.default_rng(seed)
    p = ps.psi(LEVELS, ps.a_from_jnd(jnd), pse, guess, lapse)
    return rng.binomial(n, p).astype(float), np.full(len(LEVELS), float(n))


def test_paper_model_is_logistic_regression_as_statsmodels_fits_it() -> None:
    import statsmodels.api as sm

    k, n = _draw(0.35, 0.15, 40, seed=3)
    fit = ps.fit_logistic(LEVELS, k, n)
    glm = sm.GLM(np.c_[k, n - k], sm.add_constant(LEVELS), family=sm.families.Binomial()).fit()
    b0, b1 = glm.params
    assert fit.converged
    assert fit.a == pytest.approx(b1, rel=1e-6)
    assert fit.b == pytest.approx(-b0 / b1, rel=1e-6)
    assert fit.jnd == pytest.approx(math.log(3) / b1, rel=1e-6)


def test_vectorised_fit_matches_one_at_a_time() -> None:
    rng = np.random.default_rng(5)
    k = rng.binomial(20, ps.psi(LEVELS, 12.0, 0.4), size=(30, len(LEVELS))).astype(float)
    a, b, ok = ps.fit_fixed(LEVELS, k, np.full(len(LEVELS), 20.0), 0.1, 0.02)
    for i in range(30):
        one = ps.fit_logistic(LEVELS, k[i], np.full(len(LEVELS), 20.0), 0.1, 0.02)
        assert one.converged == ok[i]
        if ok[i]:
            assert (one.a, one.b) == pytest.approx((a[i], b[i]))


def test_separated_answers_have_no_finite_fit() -> None:
    k = np.array([0.0, 0.0, 0.0, 10.0, 10.0, 10.0])
    a, b, ok = ps.fit_fixed(LEVELS, k, np.full(6, 10.0))
    assert not ok[0] and a[0] == math.inf and math.isnan(b[0])
    a, b, ok = ps.fit_fixed(LEVELS, k[::-1], np.full(6, 10.0))  # falling: -inf
    assert not ok[0] and a[0] == -math.inf and math.isnan(b[0])


@pytest.mark.parametrize(("guess", "lapse"), [(0.0, 0.0), (0.0, 0.05), (0.5, 0.03)])
def test_guess_lapse_fit_recovers_a_known_observer(guess: float, lapse: float) -> None:
    k, n = _draw(0.3, 0.12, 2000, seed=11, guess=guess, lapse=lapse)
    fit = ps.fit_guess_lapse(LEVELS, k, n)
    assert fit.converged
    assert fit.pse == pytest.approx(0.3, abs=0.03)
    assert fit.jnd == pytest.approx(0.12, abs=0.03)
    assert fit.guess == pytest.approx(guess, abs=0.04)
    assert fit.lapse == pytest.approx(lapse, abs=0.02)


def test_lapses_flatten_the_papers_model_but_not_the_guess_lapse_fit() -> None:
    # Why the toolkit reports both fits: 5% lapses make the paper's two-parameter
    # logistic shallower (a larger JND), the fit with a lapse rate does not.
    k, n = _draw(0.3, 0.1, 3000, seed=2, lapse=0.05)
    paper = ps.fit_logistic(LEVELS, k, n)
    free = ps.fit_guess_lapse(LEVELS, k, n)
    assert paper.jnd > 0.12
    assert free.jnd == pytest.approx(0.1, abs=0.015)


def test_psignifit_agrees_on_pse_jnd_and_slope() -> None:
    import psignifit  # the test extra: an independent implementation

    k, n = _draw(0.4, 0.15, 200, seed=8)
    ours = ps.fit_logistic(LEVELS, k, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = psignifit.psignifit(
            np.c_[LEVELS, k, n],
            sigmoid="logistic",
            experiment_type="yes/no",
            fixed_parameters={"lambda": 0.0, "gamma": 0.0},
            stimulus_range=(-0.5, 1.5),
            verbose=False,
        )
    loc, scale = res.standard_parameter_estimate()
    jnd = float(res.threshold(0.75, unscaled=True, return_ci=False)) - float(loc)
    # psignifit is Bayesian (MAP on a grid, with its default priors): equal
    # within a few percent, not to the last digit.
    assert ours.pse == pytest.approx(float(loc), abs=0.01)
    assert ours.jnd == pytest.approx(jnd, rel=0.05)
    assert ours.a == pytest.approx(1.0 / float(scale), rel=0.05)
