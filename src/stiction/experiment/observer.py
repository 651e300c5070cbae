"""A simulated participant: strokes a synthetic pen, watches the frames, answers.

**Strokes.** Each stimulus is approached like a person does it: the pen
hovers in from the side, touches down near the dot, rests a moment, then
drags right with a minimum-jerk profile (the bell-shaped speed of human
reaching movements, Flash & Hogan 1985, J. Neurosci. 5(7):1688) whose
length, duration and drift vary from stroke to stroke; sensor noise is
added to every sample. If the stimulus has not ended when the drag is over,
another drag follows; once it has ended the hand moves on for a reaction
time and lifts.

**Perception.** What the observer *sees* of a stimulus is the largest
visuo-haptic discrepancy it was shown: the longest string (when the string
is drawn) or else the largest gap between where the hand is and where the
pointer is (felt, not seen: noisier). Its sensation is logarithmic in that
discrepancy, ``psi = ln(1 + S / s0)``, with Gaussian noise of constant
size on the log scale (Weber's law: the just noticeable change in S is
proportional to S + s0).

**Answers.** 2AFC: the stimulus with the larger noisy sensation felt more
frictional; with probability `lapse` the answer is a coin flip. Ratio:
the felt ratio is ``(S_c / S_s) ** exponent`` times log-normal noise (a
power law of the discrepancy, Stevens' law), and it is set with the page's
buttons starting from 1.00, largest useful step first, then confirmed.

`true_curve` / `true_stevens` give what this observer would answer on
average, by running its strokes through `stiction.sim` headlessly: the
ground truth an analysis of simulated data must recover.
"""

from __future__ import annotations

import itertools
import math
import random
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from stiction.drivers.fake.strokes import DT, PenState, _min_jerk

SURFACE_M = (0.25397, 0.15237)
"""The synthetic tablet's active area (UGEE M708 v2 report descriptor)."""


@dataclass(frozen=True, slots=True)
class ObserverParams:
    """The observer's true parameters: what an analysis should find."""

    s0_px: float = 10.0
    """Sensation offset: psi = ln(1 + S/s0)."""
    sigma_string: float = 0.3
    """Sensation noise (log units) when the string is drawn."""
    sigma_nostring: float = 0.8
    """Sensation noise without the string: the discrepancy is only felt."""
    lapse: float = 0.02
    """Probability of a random answer."""
    exponent: float = 0.45
    """Ratio answers: (S_c/S_s) ** exponent."""
    ratio_sigma: float = 0.04
    """Log-normal noise of a ratio answer."""
    speed_mm_s: float = 35.0
    """Mean drag speed."""


@dataclass
class Stroke:
    """Pen states of one stimulus, produced on demand so the stroke can react."""

    rng: random.Random
    centre_m: tuple[float, float]
    speed_mm_s: float
    t: float
    ended_at: float | None = None
    lifted: bool = False
    _gen: Iterator[PenState] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self._gen = self._states()

    def end(self) -> None:
        """The stimulus ended (the page moved on): finish the movement and lift."""
        if self.ended_at is None:
            self.ended_at = self.t

    def next(self) -> PenState:
        assert self._gen is not None
        return next(self._gen)

    def _noise(self) -> float:
        return self.rng.gauss(0.0, 2e-5)  # 20 um sensor noise

    def _emit(self, x: float, y: float, tip: bool, in_range: bool = True) -> PenState:
        self.t += DT
        pressure = 0.4 + self.rng.gauss(0.0, 0.01) if tip else 0.0
        return PenState(self.t, x + self._noise(), y + self._noise(), tip, in_range, pressure)

    def _states(self) -> Iterator[PenState]:
        rng = self.rng
        cx, cy = self.centre_m
        x0, y0 = cx + rng.gauss(0.0, 7e-4), cy + rng.gauss(0.0, 7e-4)
        hx, hy = x0 - 0.006, y0 + 0.004
        n = round(rng.uniform(0.15, 0.3) / DT)
        for i in range(n):
            e = _min_jerk(i / n)
            yield self._emit(hx + (x0 - hx) * e, hy + (y0 - hy) * e, False)
        for _ in range(round(rng.uniform(0.15, 0.4) / DT)):
            yield self._emit(x0, y0, True)
        x, y = x0, y0
        while True:
            amp = rng.uniform(0.022, 0.032)
            drift = rng.gauss(0.0, 0.001)
            dur = amp / (self.speed_mm_s * 1e-3 * rng.uniform(0.8, 1.25))
            n = max(1, round(dur / DT))
            sx, sy = x, y
            for i in range(1, n + 1):
                e = _min_jerk(i / n)
                x, y = sx + amp * e, sy + drift * e
                yield self._emit(x, y, True)
                if self.ended_at is not None and self.t - self.ended_at > 0.12:
                    yield from self._lift(x, y)
                    return
            if self.ended_at is not None:
                yield from self._lift(x, y)
                return
            for _ in range(round(rng.uniform(0.05, 0.2) / DT)):  # a pause, then on
                yield self._emit(x, y, True)

    def _lift(self, x: float, y: float) -> Iterator[PenState]:
        for _ in range(10):
            yield self._emit(x, y - 0.0002, False)
        self.lifted = True
        while True:
            yield self._emit(x, y, False, in_range=False)


def discrepancy(frames: Sequence[dict[str, Any]]) -> float:
    """What a stimulus showed: the longest string if drawn, else the largest hand-pointer gap."""
    best_string: float | None = None
    best_gap = 0.0
    for fr in frames:
        for c in fr.get("contacts") or ():
            if c.get("phase") not in ("stick", "slip"):
                continue
            s = c.get("string")
            if s is not None:
                best_string = max(best_string or 0.0, float(s["length_px"]))
            best_gap = max(best_gap, math.dist(c["touch_px"], c["pointer_px"]))
    return best_gap if best_string is None else best_string


class Observer:
    """One simulated participant with known parameters and its own random stream."""

    def __init__(self, params: ObserverParams, seed: int) -> None:
        self.params = params
        self.rng = random.Random(seed)
        self.speed = params.speed_mm_s * self.rng.uniform(0.85, 1.15)

    def stroke(self, t: float) -> Stroke:
        centre = (SURFACE_M[0] / 2, SURFACE_M[1] / 2)
        return Stroke(random.Random(self.rng.random()), centre, self.speed, t)

    def sensation(self, s: float, string: bool) -> float:
        p = self.params
        sigma = p.sigma_string if string else p.sigma_nostring
        return math.log1p(s / p.s0_px) + self.rng.gauss(0.0, sigma)

    def choose_first(self, s_first: float, s_second: float, string: bool) -> bool:
        """2AFC: did the first stimulus feel more frictional?"""
        if self.rng.random() < self.params.lapse:
            return self.rng.random() < 0.5
        return self.sensation(s_first, string) > self.sensation(s_second, string)

    def felt_ratio(self, s_standard: float, s_comparison: float) -> float:
        p = self.params
        base = (max(s_comparison, 1e-6) / max(s_standard, 1e-6)) ** p.exponent
        return float(base * math.exp(self.rng.gauss(0.0, p.ratio_sigma)))

    def presses(self, target: float, start: float, steps: Sequence[float]) -> list[float]:
        """The button presses that bring `start` closest to `target`, largest step first."""
        out: list[float] = []
        value = start
        for _ in range(200):
            diff = target - value
            useful = [s for s in steps if s * diff > 0 and abs(s) <= abs(diff) + 0.005]
            if not useful:
                break
            step = max(useful, key=abs)
            out.append(step)
            value = round(value + step, 6)
        return out

    def response_time(self, presses: int) -> float:
        return self.rng.lognormvariate(math.log(0.9), 0.3) + 0.35 * presses


# ---------------------------------------------------------------- ground truth
def _mapping_scale(display: tuple[int, int]) -> float:
    """Pixels per metre of the daemon's default area mapping (letterboxed, aspect kept)."""
    return min(display[0] / SURFACE_M[0], display[1] / SURFACE_M[1])


def simulate_stimulus(
    mu_s: float,
    study_params: dict[str, float],
    display: tuple[int, int],
    travel_px: float,
    stroke: Stroke,
    string: bool,
) -> float:
    """The discrepancy one stroke shows on one surface, with stiction.sim and no daemon."""
    from stiction.sim import ContactSim, Params, Touch

    p = Params(
        k=study_params["k"],
        m=study_params["m"],
        g=study_params["g"],
        mu_s=mu_s,
        mu_k=study_params["mu_k"],
        C_l=study_params["C_l"],
    )
    sim = ContactSim(p)
    scale = _mapping_scale(display)
    origin: tuple[float, float] | None = None
    best_gap = best_string = 0.0
    tick = 1.0 / 100.0
    n = math.ceil(stroke.t / tick + 1e-9)
    t_next = n * tick
    batch: list[Touch] = []
    for _ in range(5000):
        s = stroke.next()
        # Sample times are sums of 5 ms steps: one that lands on a tick up to
        # rounding belongs to that tick, as the daemon's loop places it.
        if s.t > t_next + 1e-9:
            st = sim.advance(t_next, batch)
            batch = []
            n += 1
            t_next = n * tick
            if st.phase in ("stick", "slip"):
                if origin is None:
                    origin = (st.pointer_x, st.pointer_y)
                gap = math.hypot(st.touch_x - st.pointer_x, st.touch_y - st.pointer_y) * scale
                best_gap = max(best_gap, gap)
                best_string = max(best_string, st.string_px)
                moved = math.hypot(st.pointer_x - origin[0], st.pointer_y - origin[1]) * scale
                if moved >= travel_px:
                    break
        if s.tip and s.in_range:
            batch.append(Touch(s.t, s.x, s.y, True))
        elif s.in_range:
            batch.append(Touch(s.t, s.x, s.y, False))
    return best_string if string else best_gap


def shown_discrepancies(
    observer_params: ObserverParams,
    mu_values: Sequence[float],
    study_params: dict[str, float],
    display: tuple[int, int],
    travel_px: float,
    string: bool,
    strokes: int = 12,
    seed: int = 7,
) -> dict[float, list[float]]:
    """For each mu_s, the discrepancies of `strokes` typical strokes (headless).

    Each stroke comes from another simulated participant, so the truth
    averages over their speeds as a study's pooled data do."""
    out: dict[float, list[float]] = {}
    for mu in mu_values:
        out[mu] = [
            simulate_stimulus(
                mu,
                study_params,
                display,
                travel_px,
                Observer(observer_params, seed * 1000 + i).stroke(0.0),
                string,
            )
            for i in range(strokes)
        ]
    return out


def _phi(z: float) -> float:
    return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))


def true_curve(
    observer_params: ObserverParams,
    mu_values: Sequence[float],
    standard_mu_s: float,
    study_params: dict[str, float],
    display: tuple[int, int],
    travel_px: float,
    string: bool,
    strokes: int = 12,
) -> dict[float, float]:
    """P(comparison felt more frictional) at each mu_s: the observer's psychometric function.

    Averaged over pairs of typical strokes; the decision noise is integrated
    exactly (the difference of two Gaussian sensations is Gaussian)."""
    p = observer_params
    sigma = p.sigma_string if string else p.sigma_nostring
    mus = sorted({*mu_values, standard_mu_s})
    shown = shown_discrepancies(p, mus, study_params, display, travel_px, string, strokes)
    out: dict[float, float] = {}
    for mu in mu_values:
        probs = [
            _phi((math.log1p(c / p.s0_px) - math.log1p(s / p.s0_px)) / (sigma * math.sqrt(2.0)))
            for c in shown[mu]
            for s in shown[standard_mu_s]
        ]
        out[mu] = p.lapse / 2 + (1 - p.lapse) * sum(probs) / len(probs)
    return out


def logistic_truth(curve: dict[float, float]) -> tuple[float, float]:
    """PSE and JND of the paper's logistic f(x) = 1/(1+exp(-A(x-B))) closest to `curve`.

    The observer's curve is not exactly logistic in mu_s (its sensation is
    logarithmic in a discrepancy that grows like mu_s or its square root), so
    what a logistic fit to its answers converges to, with equally many trials
    per level, is the logistic maximising the expected log-likelihood of the
    true proportions: a logistic regression on fractional responses, solved
    here by iteratively reweighted least squares. PSE = B, JND = ln 3 / A
    (the 75% point minus the PSE), as in the paper.
    """
    xs = sorted(curve)
    alpha, beta = 0.0, 1.0
    for _ in range(100):
        g0 = g1 = h00 = h01 = h11 = 0.0
        for x in xs:
            f = 1.0 / (1.0 + math.exp(-(alpha + beta * x)))
            r, w = curve[x] - f, f * (1.0 - f)
            g0, g1 = g0 + r, g1 + r * x
            h00, h01, h11 = h00 + w, h01 + w * x, h11 + w * x * x
        det = h00 * h11 - h01 * h01
        da, db = (h11 * g0 - h01 * g1) / det, (h00 * g1 - h01 * g0) / det
        alpha, beta = alpha + da, beta + db
        if abs(da) + abs(db) < 1e-12:
            break
    return -alpha / beta, math.log(3.0) / beta


def pse_jnd(curve: dict[float, float]) -> tuple[float, float]:
    """PSE (the 50% point) and JND (75% point minus PSE), by linear interpolation."""

    def crossing(level: float) -> float:
        pts = sorted(curve.items())
        if pts[0][1] >= level:
            return pts[0][0]
        for (x0, y0), (x1, y1) in itertools.pairwise(pts):
            if y0 < level <= y1:
                return x0 + (level - y0) * (x1 - x0) / (y1 - y0)
        return math.inf

    pse = crossing(0.5)
    return pse, crossing(0.75) - pse


def true_stevens(
    observer_params: ObserverParams,
    mu_values: Sequence[float],
    standard_mu_s: float,
    study_params: dict[str, float],
    display: tuple[int, int],
    travel_px: float,
    strokes: int = 12,
) -> tuple[float, float, dict[float, float]]:
    """(k, beta, mean ratio per mu_s): the Stevens power law this observer follows.

    The mean ratio is E[(S_c/S_s)^a] times the log-normal mean; k and beta are
    the least-squares fit of k * mu_s^beta to those means (Gauss-Newton from
    the log-log line), as Stevens' law is fitted to a study's level means."""
    p = observer_params
    mus = sorted({*mu_values, standard_mu_s})
    shown = shown_discrepancies(p, mus, study_params, display, travel_px, True, strokes)
    noise = math.exp(p.ratio_sigma**2 / 2)
    mean: dict[float, float] = {}
    for mu in mu_values:
        vals = [(c / s) ** p.exponent for c in shown[mu] for s in shown[standard_mu_s]]
        mean[mu] = noise * sum(vals) / len(vals)
    xs = [math.log(m) for m in mu_values]
    ys = [math.log(mean[m]) for m in mu_values]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    beta = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum(
        (x - mx) ** 2 for x in xs
    )
    k = math.exp(my - beta * mx)
    for _ in range(50):
        g0 = g1 = h00 = h01 = h11 = 0.0
        for mu in mu_values:
            f = k * mu**beta
            r = mean[mu] - f
            jk, jb = mu**beta, f * math.log(mu)
            g0, g1 = g0 + jk * r, g1 + jb * r
            h00, h01, h11 = h00 + jk * jk, h01 + jk * jb, h11 + jb * jb
        det = h00 * h11 - h01 * h01
        dk, db = (h11 * g0 - h01 * g1) / det, (h00 * g1 - h01 * g0) / det
        k, beta = k + dk, beta + db
        if abs(dk) + abs(db) < 1e-13:
            break
    return k, beta, mean
