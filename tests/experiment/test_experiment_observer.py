"""The simulated observer's pieces: strokes, answers, and the truth functions."""

from __future__ import annotations

import itertools
import math

import pytest

from stiction.experiment.observer import (
    DT,
    Observer,
    ObserverParams,
    logistic_truth,
    pse_jnd,
)


def test_logistic_truth_returns_a_logistic_curves_own_parameters() -> None:
    a, b = 7.0, 0.3
    curve = {x / 5: 1 / (1 + math.exp(-a * (x / 5 - b))) for x in range(6)}
    pse, jnd = logistic_truth(curve)
    assert pse == pytest.approx(b, abs=1e-9)
    assert jnd == pytest.approx(math.log(3) / a, abs=1e-9)


def test_pse_jnd_reads_the_curve() -> None:
    curve = {0.0: 0.4, 0.5: 0.6, 1.0: 0.8}
    pse, jnd = pse_jnd(curve)
    assert pse == pytest.approx(0.25) and jnd == pytest.approx(0.875 - 0.25)


def test_ratio_presses_reach_the_target_largest_step_first() -> None:
    obs = Observer(ObserverParams(), 1)
    steps = (-0.10, -0.05, -0.01, 0.01, 0.05, 0.10)
    assert obs.presses(1.16, 1.0, steps) == [0.10, 0.05, 0.01]
    assert obs.presses(0.87, 1.0, steps) == [-0.10, -0.01, -0.01, -0.01]
    assert obs.presses(1.003, 1.0, steps) == []


def test_a_stroke_is_a_human_reach_and_lifts_after_the_end() -> None:
    obs = Observer(ObserverParams(), 3)
    stroke = obs.stroke(0.0)
    states = [stroke.next() for _ in range(400)]
    touching = [s for s in states if s.tip]
    assert not states[0].tip and touching  # hovers in, then touches
    speeds = [abs(b.x - a.x) / DT for a, b in itertools.pairwise(touching)]
    peak = max(speeds)
    assert 0.03 < peak < 0.12  # m/s: a hand's drag, not a jump
    assert speeds.index(peak) > 10  # accelerates smoothly from rest
    stroke.end()
    rest = [stroke.next() for _ in range(100)]
    assert stroke.lifted and not rest[-1].tip


def test_two_afc_answers_follow_the_larger_discrepancy() -> None:
    obs = Observer(ObserverParams(lapse=0.0), 5)
    firsts = sum(obs.choose_first(60.0, 20.0, True) for _ in range(200))
    assert firsts > 190  # 60 px against 20 px is far above the noise
    even = sum(obs.choose_first(30.0, 30.0, True) for _ in range(2000))
    assert 900 < even < 1100
