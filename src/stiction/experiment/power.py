"""How many trials and participants a 2AFC study needs to pin the JND down, by simulation.

The simulated observer here is parametric: it answers "comparison more
frictional" with probability psi(mu_s) = gamma + (1 - gamma - lambda) f(mu_s),
f the paper's logistic with the given PSE and JND. It is not the stroke-level
simulated participant of `stiction experiment simulate` (which moves a pen
through the friction model): power questions are about the statistics of
binary answers, and thousands of simulated experiments must run in seconds.

Two questions, both answered by running many seeded simulated experiments:

* the method of constant stimuli (the paper's design: every level of the
  study, `repetitions` times each, shuffled): for participants x repetitions,
  how far the pooled JND estimate falls from the truth -- the 95th
  percentile of |JND_hat - JND| is the "precision";
* constant stimuli against QUEST+ (Watson 2017, J. Vision 17(3):10, through
  the `questplus` package): for one observer, how many trials each needs
  before 95% of simulated runs estimate the JND within the same precision.

Both estimators know the observer's guess and lapse rates (a design choice
that isolates what the stimulus placement buys). Constant stimuli fits the
logistic by maximum likelihood (`psychometric.fit_fixed`); QUEST+ keeps a
posterior over a cumulative-normal model (its package offers no logistic)
and estimates JND = 0.6745 sd, the 75% point of the normal minus its mean
(0.6745 is the normal's 75% quantile). The logistic observer and the normal
model differ a little in the tails; that mismatch is part of what is measured.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from stiction.experiment import psychometric as ps

Z75 = 0.6744897501960817  # the standard normal's 75% quantile (scipy.stats.norm.ppf(0.75))
COVER = 0.95  # a precision holds when 95% of simulated estimates fall within it


@dataclass(frozen=True)
class Observer:
    """A psychometric observer on the mu_s axis."""

    pse: float
    jnd: float
    guess: float = 0.0
    lapse: float = 0.02

    def p(self, x: np.ndarray) -> np.ndarray:
        return ps.psi(x, ps.a_from_jnd(self.jnd), self.pse, self.guess, self.lapse)


def _error_quantile(estimates: np.ndarray, truth: float) -> float:
    """The COVER quantile of |estimate - truth|; a failed fit counts as an infinite error."""
    err = np.where(np.isfinite(estimates), np.abs(estimates - truth), np.inf)
    return float(np.quantile(err, COVER, method="higher"))


def constant_stimuli_error(
    observer: Observer,
    levels: np.ndarray,
    participants: int,
    repetitions: int,
    simulations: int,
    rng: np.random.Generator,
    participant_pse_sd: float = 0.0,
) -> float:
    """95th percentile of the pooled JND's error over simulated constant-stimuli studies."""
    x = np.asarray(levels, dtype=float)
    a = ps.a_from_jnd(observer.jnd)
    # Each simulated participant has its own PSE when participant_pse_sd > 0.
    pse = observer.pse + participant_pse_sd * rng.standard_normal((simulations, participants, 1))
    scale = 1 - observer.guess - observer.lapse
    p = observer.guess + scale / (1 + np.exp(-a * (x[None, None, :] - pse)))
    k = rng.binomial(repetitions, p).sum(axis=1).astype(float)
    n = np.full(len(x), float(repetitions * participants))
    a_hat, _, ok = ps.fit_fixed(x, k, n, observer.guess, observer.lapse)
    jnd = np.where(ok, ps.LN3 / np.where(ok, a_hat, 1.0), np.nan)
    return _error_quantile(jnd, observer.jnd)


@dataclass(frozen=True)
class DesignRow:
    participants: int
    repetitions: int
    trials_per_participant: int
    jnd_error95: float
    meets: bool


def design_table(
    observer: Observer,
    levels: list[float],
    precision: float,
    participants: list[int],
    repetitions: list[int],
    simulations: int,
    seed: int,
    participant_pse_sd: float = 0.0,
) -> list[DesignRow]:
    """The JND error for each participants x repetitions of a constant-stimuli study."""
    rng = np.random.default_rng(seed)
    rows = []
    for n_people in participants:
        for reps in repetitions:
            err = constant_stimuli_error(
                observer, np.array(levels), n_people, reps, simulations, rng, participant_pse_sd
            )
            rows.append(DesignRow(n_people, reps, reps * len(levels), err, bool(err <= precision)))
    return rows


def cheapest(rows: list[DesignRow]) -> DesignRow | None:
    """The design that meets the precision with the fewest trials in all (then fewest people)."""
    meeting = [r for r in rows if r.meets]
    if not meeting:
        return None
    return min(meeting, key=lambda r: (r.participants * r.trials_per_participant, r.participants))


def param_grid(levels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """QUEST+'s grid of the normal model's mean and sd over a stimulus range."""
    span = float(levels.max() - levels.min())
    step = float(np.diff(np.unique(levels)).min()) if len(np.unique(levels)) > 1 else span / 10
    means = np.linspace(levels.min() - 0.2 * span, levels.max(), 25)
    sds = np.geomspace(step / 4, span, 20)  # a quarter of the finest spacing to the range
    return means, sds


def _quest(levels: np.ndarray, observer: Observer, grid_of: np.ndarray) -> Any:
    import questplus

    means, sds = param_grid(grid_of)
    return questplus.QuestPlus(
        stim_domain={"intensity": levels},
        param_domain={
            "mean": means,
            "sd": sds,
            "lower_asymptote": [observer.guess],
            "lapse_rate": [observer.lapse],
        },
        outcome_domain={"response": ["Yes", "No"]},
        func="norm_cdf",
        stim_scale="linear",
        stim_selection_method="min_entropy",
        param_estimation_method="mean",
    )


def bayes_jnd(
    x: np.ndarray, k: np.ndarray, n: np.ndarray, observer: Observer, grid_of: np.ndarray
) -> np.ndarray:
    """QUEST+'s estimate from counts, for many data sets at once: JND = 0.6745 E[sd].

    The posterior over the same (mean, sd) grid, model and uniform prior as
    `_quest`, from `k` "comparison" answers of `n` at the levels `x` (rows:
    data sets). Order does not matter to a posterior, so constant stimuli can
    be scored with exactly the estimator QUEST+ uses and the comparison is
    about where the trials go, not how they are analysed (a test checks this
    against questplus itself).
    """
    from scipy.special import ndtr

    means, sds = param_grid(grid_of)
    scale = 1 - observer.guess - observer.lapse
    z = (x[None, None, :] - means[:, None, None]) / sds[None, :, None]
    p = np.clip(observer.guess + scale * ndtr(z), 1e-12, 1 - 1e-12)  # mean x sd x level
    ks = np.atleast_2d(k)
    ns = np.broadcast_to(np.atleast_2d(n), ks.shape)
    loglik = np.einsum("il,msl->ims", ks, np.log(p)) + np.einsum(
        "il,msl->ims", ns - ks, np.log1p(-p)
    )
    loglik -= loglik.max(axis=(1, 2), keepdims=True)
    post = np.exp(loglik)
    post /= post.sum(axis=(1, 2), keepdims=True)
    return np.asarray(Z75 * np.einsum("ims,s->i", post, sds))


def quest_run(
    observer: Observer, levels: np.ndarray, checkpoints: list[int], rng: np.random.Generator
) -> list[float]:
    """One QUEST+ run: the JND estimate after each checkpoint's number of trials."""
    q = _quest(levels, observer, levels)
    out = []
    last = max(checkpoints)
    marks = set(checkpoints)
    for trial in range(1, last + 1):
        stim = q.next_stim
        p = float(observer.p(np.array([stim["intensity"]]))[0])
        q.update(stim=stim, outcome={"response": "Yes" if rng.random() < p else "No"})
        if trial in marks:
            out.append(Z75 * float(q.param_estimate["sd"]))
    return out


@dataclass(frozen=True)
class MethodCurve:
    method: str
    trials: list[int]
    jnd_error95: list[float]
    trials_needed: int | None  # from this many trials on, every count meets the precision


def _needed(trials: list[int], errors: list[float], precision: float) -> int | None:
    """The fewest trials from which on every longer run meets the precision too.

    Not merely the first count that meets it: with a finite number of
    simulated runs the error curve is noisy, and one lucky count is no answer.
    """
    needed = None
    for t, e in reversed(list(zip(trials, errors, strict=True))):
        if e > precision:
            break
        needed = t
    return needed


def compare_methods(
    observer: Observer,
    levels: list[float],
    precision: float,
    max_trials: int,
    simulations: int,
    seed: int,
    quest_levels: int = 26,
    mcs_simulations: int | None = None,
) -> list[MethodCurve]:
    """Constant stimuli vs QUEST+ for one observer: JND error against trials spent.

    Constant stimuli runs whole repetitions of `levels` and is scored twice:
    with the paper's analysis (the ML logistic fit) and with QUEST+'s own
    Bayesian estimate. QUEST+ chooses each stimulus from `quest_levels` evenly
    spaced values over the same range. Constant stimuli is cheap to simulate
    and gets `mcs_simulations` runs (default: as many as QUEST+).
    """
    rng = np.random.default_rng(seed)
    x = np.array(levels, dtype=float)
    grid = np.round(np.linspace(x.min(), x.max(), quest_levels), 6)
    mcs_runs = mcs_simulations or simulations
    reps = list(range(1, max(1, max_trials // len(x)) + 1))
    mcs_trials = [r * len(x) for r in reps]
    ml_err, bayes_err = [], []
    for r in reps:
        k = rng.binomial(r, observer.p(x), size=(mcs_runs, len(x))).astype(float)
        n = np.full(len(x), float(r))
        a_hat, _, ok = ps.fit_fixed(x, k, n, observer.guess, observer.lapse)
        ml_err.append(
            _error_quantile(np.where(ok, ps.LN3 / np.where(ok, a_hat, 1.0), np.nan), observer.jnd)
        )
        bayes_err.append(_error_quantile(bayes_jnd(x, k, n, observer, grid), observer.jnd))
    checkpoints = sorted({t for t in mcs_trials if t <= max_trials} | {max_trials})
    runs = np.array([quest_run(observer, grid, checkpoints, rng) for _ in range(simulations)])
    q_err = [_error_quantile(runs[:, i], observer.jnd) for i in range(len(checkpoints))]
    return [
        MethodCurve(
            "constant stimuli, ML fit",
            mcs_trials,
            ml_err,
            _needed(mcs_trials, ml_err, precision),
        ),
        MethodCurve(
            "constant stimuli, Bayes",
            mcs_trials,
            bayes_err,
            _needed(mcs_trials, bayes_err, precision),
        ),
        MethodCurve("QUEST+", checkpoints, q_err, _needed(checkpoints, q_err, precision)),
    ]


def as_dict(obj: Any) -> Any:
    """Dataclasses (and lists of them) as plain dicts for --json; infinities as None."""
    from stiction.experiment.report import jsonable

    if isinstance(obj, list):
        return [as_dict(o) for o in obj]
    return jsonable(asdict(obj))
