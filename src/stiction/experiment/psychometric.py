"""Psychometric functions for the 2AFC study: the paper's logistic, fitted by maximum likelihood.

The paper (User study 1) fits f(x) = 1 / (1 + exp(-A (x - B))) to the
proportion of "comparison more frictional" answers, with x the comparison's
static friction coefficient mu_s. Here x is always mu_s as set in the trial
(`comparison_mu_s`), so B, the point of subjective equality (PSE), is in mu_s
and A in 1/mu_s; the JND, the 75% point minus the PSE, is ln(3)/A in mu_s.

Two models:

* the paper's logistic (guess and lapse rates 0): a logistic regression of
  the answers on mu_s, logit p = b0 + b1 x with A = b1 and B = -b0/b1;
* the same logistic inside guess and lapse rates,
  psi(x) = gamma + (1 - gamma - lambda) f(x), which keeps a few random
  answers (lapses) or a floor of guesses from flattening the slope. PSE and
  JND are those of the inner f, so they mean the same as in the paper's model.

`fit_fixed` fits (A, B) with gamma and lambda held fixed, vectorised over
many data sets at once by Fisher scoring: a bootstrap of 1,000 resamples is
one call instead of 1,000 optimiser runs. With gamma = lambda = 0 it is
ordinary logistic regression (the tests check it against statsmodels' GLM).
`fit_guess_lapse_many` frees gamma and lambda on a grid (running `fit_fixed`
for every grid point and data set in one batch); `fit_guess_lapse` refines
one data set's grid optimum continuously with scipy's L-BFGS-B.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

LN3 = math.log(3.0)  # logit(0.75): the 75% point lies ln(3)/A above the PSE
# Bounds for the free guess and lapse rates: a 2AFC observer guesses at most
# half the time, and more than 10% lapses says the task, not the observer,
# is broken (Wichmann & Hill 2001 use a lapse prior of the same order).
GUESS_MAX = 0.5
LAPSE_MAX = 0.1
GUESS_GRID = np.round(np.arange(0.0, GUESS_MAX + 1e-9, 0.05), 2)
LAPSE_GRID = np.round(np.arange(0.0, LAPSE_MAX + 1e-9, 0.01), 2)
# A slope that changes the log-odds by more than this between neighbouring
# levels is a step function: the data are separated and have no finite ML fit.
STEP_LOGODDS = 20.0

Float = NDArray[np.float64]


def logistic(x: ArrayLike, a: float, b: float) -> Float:
    """The paper's f(x) = 1 / (1 + exp(-A (x - B)))."""
    z = -a * (np.asarray(x, dtype=float) - b)
    return np.asarray(1.0 / (1.0 + np.exp(np.clip(z, -700, 700))), dtype=float)


def psi(x: ArrayLike, a: float, b: float, guess: float = 0.0, lapse: float = 0.0) -> Float:
    """The probability of "comparison" with guess and lapse rates around the logistic."""
    return np.asarray(guess + (1.0 - guess - lapse) * logistic(x, a, b), dtype=float)


def a_from_jnd(jnd: float) -> float:
    """The slope A whose 75% point lies `jnd` above the PSE."""
    return LN3 / jnd


@dataclass(frozen=True)
class Fit:
    """One fitted psychometric function; PSE and JND in mu_s."""

    a: float
    b: float
    guess: float
    lapse: float
    converged: bool
    loglik: float

    @property
    def pse(self) -> float:
        return self.b

    @property
    def jnd(self) -> float:
        return LN3 / self.a if self.a != 0 else math.inf


def _slope_limit(xs: Float) -> float:
    """The largest slope A still told apart from a step at these stimulus levels."""
    levels = np.unique(xs)
    spacing = float(np.diff(levels).min()) if len(levels) > 1 else 1.0
    return STEP_LOGODDS / spacing


def _loglik(k: Float, n: Float, p: Float) -> Float:
    p = np.clip(p, 1e-12, 1 - 1e-12)
    return np.asarray((k * np.log(p) + (n - k) * np.log1p(-p)).sum(axis=-1), dtype=float)


def fit_fixed(
    x: ArrayLike,
    k: ArrayLike,
    n: ArrayLike,
    guess: ArrayLike = 0.0,
    lapse: ArrayLike = 0.0,
    iterations: int = 100,
) -> tuple[Float, Float, NDArray[np.bool_]]:
    """Maximum-likelihood (A, B) for counts `k` of `n` at levels `x`; gamma, lambda fixed.

    `k` and `n` may have a leading axis of data sets (shape (R, L)); the
    result is then arrays of R values of A and B and a flag per data set that
    says the fit converged. A data set whose answers are perfectly separated
    along x has no finite maximum; its slope grows past every bound and it
    is reported as not converged with A = +-inf and B = NaN (any other
    failure to converge: both NaN).
    """
    xs = np.asarray(x, dtype=float)
    ks = np.atleast_2d(np.asarray(k, dtype=float))
    ns = np.atleast_2d(np.asarray(n, dtype=float))
    ns = np.broadcast_to(ns, ks.shape)
    # guess and lapse: one value for all data sets, or one per data set.
    gs = np.broadcast_to(np.asarray(guess, dtype=float), ks.shape[:1])[:, None]
    scale = 1.0 - gs - np.broadcast_to(np.asarray(lapse, dtype=float), ks.shape[:1])[:, None]
    if not ((scale > 0.0) & (scale <= 1.0)).all():
        raise ValueError("guess + lapse must stay below 1")
    span = float(xs.max() - xs.min()) or 1.0
    # Start from a moderate slope at the middle of the range: every data set
    # that has a finite maximum is reached from there with damped steps.
    b0 = np.full(ks.shape[0], -(xs.mean()) * 4.0 / span)
    b1 = np.full(ks.shape[0], 4.0 / span)
    done = np.zeros(ks.shape[0], dtype=bool)
    limit = _slope_limit(xs)
    for _ in range(iterations):
        act = np.flatnonzero(~done)  # only the data sets still moving cost work
        if act.size == 0:
            break
        c0, c1 = b0[act], b1[act]
        ka, na, ga, sa = ks[act], ns[act], gs[act], scale[act]
        s = 1.0 / (1.0 + np.exp(-np.clip(c0[:, None] + c1[:, None] * xs, -700, 700)))
        p = np.clip(ga + sa * s, 1e-12, 1 - 1e-12)
        dp = sa * s * (1.0 - s)
        w = na * dp * dp / (p * (1.0 - p))
        r = (ka - na * p) * dp / (p * (1.0 - p))
        g0, g1 = r.sum(axis=1), (r * xs).sum(axis=1)
        i00, i01, i11 = w.sum(axis=1), (w * xs).sum(axis=1), (w * xs * xs).sum(axis=1)
        det = i00 * i11 - i01 * i01
        ok = det > 1e-300
        d0 = np.where(ok, (i11 * g0 - i01 * g1) / np.where(ok, det, 1.0), 0.0)
        d1 = np.where(ok, (i00 * g1 - i01 * g0) / np.where(ok, det, 1.0), 0.0)
        # Damping: no step changes the log-odds across the range by more than
        # 10, which keeps Fisher scoring from overshooting from a poor start.
        size = np.maximum(np.abs(d1) * span, np.abs(d0 + d1 * xs.mean()))
        damp = np.minimum(1.0, 10.0 / np.maximum(size, 1e-300))
        c0, c1 = c0 + d0 * damp, c1 + d1 * damp
        b0[act], b1[act] = c0, c1
        # Separated data stall once the fitted probabilities reach 0 and 1,
        # so a slope past the limit ends the iteration as not converged.
        done[act] = ((np.abs(d1) * span < 1e-7) & (np.abs(d0) < 1e-7)) | (np.abs(c1) > limit)
    converged = done & (np.abs(b1) <= limit) & (b1 != 0)
    # Separated answers: the slope is infinite (its sign kept), the PSE unknown.
    steep = np.abs(b1) > limit
    a = np.where(converged, b1, np.where(steep, np.sign(b1) * np.inf, np.nan))
    b = np.where(converged, -b0 / np.where(b1 != 0, b1, 1.0), np.nan)
    return a, b, converged


def fit_logistic(
    x: ArrayLike, k: ArrayLike, n: ArrayLike, guess: float = 0.0, lapse: float = 0.0
) -> Fit:
    """The ML fit of one data set with fixed guess and lapse rates (default: the paper's model)."""
    a, b, conv = fit_fixed(x, k, n, guess, lapse)
    ks = np.asarray(k, dtype=float)
    p = psi(x, float(a[0]), float(b[0]), guess, lapse) if conv[0] else np.full(ks.shape, 0.5)
    ll = float(_loglik(ks, np.asarray(n, dtype=float), p))
    return Fit(float(a[0]), float(b[0]), guess, lapse, bool(conv[0]), ll)


def fit_guess_lapse_many(
    x: ArrayLike, k: ArrayLike, n: ArrayLike
) -> tuple[Float, Float, Float, Float, NDArray[np.bool_]]:
    """ML (A, B, gamma, lambda) of many data sets at once, on a grid of the two rates.

    For every (gamma, lambda) of `GUESS_GRID` x `LAPSE_GRID` the slope and PSE
    are fitted by `fit_fixed` (vectorised over data sets); each data set keeps
    the grid point of highest likelihood. The rates are thus known to the grid
    step (0.05 and 0.01), which is what a bootstrap needs; `fit_guess_lapse`
    refines a single fit continuously.
    """
    xs = np.asarray(x, dtype=float)
    ks = np.atleast_2d(np.asarray(k, dtype=float))
    ns = np.broadcast_to(np.atleast_2d(np.asarray(n, dtype=float)), ks.shape)
    r = ks.shape[0]
    gg, ll = np.meshgrid(GUESS_GRID, LAPSE_GRID, indexing="ij")
    g_rows = np.repeat(gg.ravel(), r)  # grid point major, data set minor
    l_rows = np.repeat(ll.ravel(), r)
    m = gg.size
    k_rows, n_rows = np.tile(ks, (m, 1)), np.tile(ns, (m, 1))
    a, b, conv = fit_fixed(xs, k_rows, n_rows, g_rows, l_rows)
    eta = np.nan_to_num(a)[:, None] * (xs[None, :] - np.nan_to_num(b)[:, None])
    p = g_rows[:, None] + (1 - g_rows - l_rows)[:, None] / (1 + np.exp(-np.clip(eta, -700, 700)))
    loglik = np.where(conv, _loglik(k_rows, n_rows, p), -np.inf).reshape(m, r)
    pick = loglik.argmax(axis=0)
    rows = pick * r + np.arange(r)
    ok = np.isfinite(loglik.max(axis=0))
    nan = np.full(r, np.nan)
    return (
        np.where(ok, a[rows], nan),
        np.where(ok, b[rows], nan),
        np.where(ok, g_rows[rows], nan),
        np.where(ok, l_rows[rows], nan),
        ok,
    )


def fit_guess_lapse(x: ArrayLike, k: ArrayLike, n: ArrayLike) -> Fit:
    """The ML fit with free guess (0..0.5) and lapse (0..0.1) rates: grid, then L-BFGS-B."""
    from scipy.optimize import minimize

    xs = np.asarray(x, dtype=float)
    ks, ns = np.asarray(k, dtype=float), np.asarray(n, dtype=float)
    a0, b0, g0, l0, ok = fit_guess_lapse_many(xs, ks, ns)
    if not ok[0]:
        return Fit(math.nan, math.nan, math.nan, math.nan, False, math.nan)
    limit = _slope_limit(xs)
    if a0[0] <= 0:  # a falling curve: no refinement in log A; the grid fit stands
        p = psi(xs, a0[0], b0[0], g0[0], l0[0])
        return Fit(a0[0], b0[0], g0[0], l0[0], True, float(_loglik(ks, ns, p)))

    def nll(theta: Float) -> float:
        log_a, b, g, lam = theta
        return -float(_loglik(ks, ns, psi(xs, math.exp(log_a), b, g, lam)))

    span = float(xs.max() - xs.min()) or 1.0
    lo, hi = float(xs.min()) - span, float(xs.max()) + span
    bounds = [(math.log(1e-3 / span), math.log(limit)), (lo, hi), (0, GUESS_MAX), (0, LAPSE_MAX)]
    theta0 = np.array([math.log(a0[0]), min(max(b0[0], lo), hi), g0[0], l0[0]])
    res = minimize(nll, theta0, method="L-BFGS-B", bounds=bounds)
    theta = res.x if res.fun <= nll(theta0) else theta0
    log_a, b, g, lam = (float(v) for v in theta)
    steep = math.exp(log_a) >= limit * 0.999
    return Fit(math.exp(log_a), b, g, lam, not steep, -nll(theta))


def counts(x: ArrayLike, y: ArrayLike) -> tuple[Float, Float, Float]:
    """Levels, "comparison" answers and trials per level, from per-trial x and 0/1 answers."""
    xs = np.asarray(x, dtype=float)
    ys = np.asarray(y, dtype=float)
    levels = np.unique(xs)
    k = np.array([ys[xs == v].sum() for v in levels])
    n = np.array([float((xs == v).sum()) for v in levels])
    return levels, k, n
