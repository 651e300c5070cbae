"""The exact integrator against the paper's 1-D solution, written out independently here."""

from __future__ import annotations

import math

import pytest
from sim_helpers import drive, sampled

from stiction.sim import INTEGRATORS, ContactSim, Params, Touch
from stiction.sim.integrators import DEFAULT_INTEGRATOR


def paper_1d(p: Params, v: float, t: float) -> tuple[float, float, str]:
    """Pen position and velocity for a touch moving at constant v > 0 from rest at 0.

    Stuck until k*v*t = F_s; then (model.md) at rest in slip until the net
    force k*s + c*v exceeds F_k; then m x'' + c x' + k x = -F_k with
    x = p - u (paper eq. 1): critically damped from x(0) = -v*ts, x'(0) = -v.
    """
    tb = p.F_s / (p.k * v)
    ts = max(p.F_s, p.F_k - p.c * v) / (p.k * v)
    if t <= tb:
        return 0.0, 0.0, "stick"
    if t <= ts:
        return 0.0, 0.0, "slip"
    w = math.sqrt(p.k / p.m)
    tau = t - ts
    xe = -p.F_k / p.k
    y0 = -v * ts - xe
    yd0 = -v
    e = math.exp(-w * tau)
    y = (y0 + (yd0 + w * y0) * tau) * e
    yd = (yd0 - w * (yd0 + w * y0) * tau) * e
    return v * t + xe + y, v + yd, "slip"


@pytest.mark.parametrize("v", [0.005, 0.02, 0.1, 0.5])
@pytest.mark.parametrize("mu_s", [0.0, 0.3, 1.0])
@pytest.mark.parametrize("rate", [100.0, 200.0, 400.0])
def test_exact_matches_the_closed_form_at_every_tick(v: float, mu_s: float, rate: float) -> None:
    p = Params(mu_s=mu_s)
    sim = ContactSim(p, "exact")
    # Samples on the tick times make the model's touch path exactly the line u = v t
    # (elsewhere it is held at the last sample at each tick, as a live daemon must).
    states = drive(sim, sampled(lambda t: (v * t, 0.0), 0.0, 1.0, rate=rate), 0.0, 1.0)
    for st in states[1:]:
        px, pv, phase = paper_1d(p, v, st.t)
        assert st.pointer_x == pytest.approx(px, abs=1e-12)
        assert st.vx == pytest.approx(pv, abs=1e-10)
        assert st.pointer_y == 0.0
        if abs(st.t - p.F_s / (p.k * v)) > 1e-9:
            assert st.phase == phase


def test_release_is_located_inside_the_tick() -> None:
    p = Params()
    v = 0.02
    tb = p.F_s / (p.k * v)  # 0.343 s: between ticks
    located = drive(ContactSim(p, "exact"), sampled(lambda t: (v * t, 0.0), 0, 0.4), 0, 0.4)
    naive = drive(
        ContactSim(p, "exact", events=False), sampled(lambda t: (v * t, 0), 0, 0.4), 0, 0.4
    )
    at = next(s for s in located if s.t > tb)
    assert at.pointer_x == pytest.approx(paper_1d(p, v, at.t)[0], abs=1e-12)
    late = next(s for s in naive if s.t > tb)
    # Without event location the release waits for the end of the step it
    # happens in (here the 200 Hz sample after tb), so the pen lags behind.
    assert late.phase == "slip"
    assert 0.0 <= late.pointer_x < at.pointer_x - 1e-6


def test_fine_rk4_converges_to_exact_on_stop_and_go() -> None:
    def path(t: float) -> tuple[float, float]:
        return 0.02 * t - 0.02 * math.sin(3 * math.pi * t) / (3 * math.pi), 0.0

    samples = sampled(path, 0.0, 2.0)
    ex = drive(ContactSim(Params(), "exact"), samples, 0.0, 2.0)
    rk = drive(ContactSim(Params(), "rk4", 256, events=True), samples, 0.0, 2.0)
    assert {s.phase for s in ex} == {"stick", "slip"}
    assert max(abs(a.pointer_x - b.pointer_x) for a, b in zip(ex, rk, strict=True)) < 1e-9
    assert [a.phase for a in ex] == [b.phase for b in rk]


def test_every_integrator_name_runs_and_default_resolves() -> None:
    samples = sampled(lambda t: (0.03 * t, 0.01 * math.sin(4 * t)), 0.0, 1.0)
    for name in INTEGRATORS:
        sim = ContactSim(Params(), name)
        states = drive(sim, samples, 0.0, 1.0)
        assert {s.phase for s in states} >= {"stick", "slip"}, name
    assert ContactSim(Params(), "default").integrator == DEFAULT_INTEGRATOR


def test_every_sample_is_followed_not_only_tick_endpoints() -> None:
    """A there-and-back excursion between two ticks must still drag a sliding pen."""
    p = Params(mu_s=0.0, mu_k=0.0)
    sim = ContactSim(p)
    sim.advance(0.0, [Touch(0.0, 0.0, 0.0)])
    a = sim.advance(0.01, [Touch(0.005, 0.01, 0.0), Touch(0.01, 0.0, 0.0)])
    sim2 = ContactSim(p)
    sim2.advance(0.0, [Touch(0.0, 0.0, 0.0)])
    b = sim2.advance(0.01, [Touch(0.01, 0.0, 0.0)])
    assert a.touch_x == b.touch_x == 0.0
    assert b.pointer_x == 0.0
    assert a.pointer_x > 1e-4  # the pen went out after the touch and is still on its way


def test_touch_is_held_at_the_tick_and_moves_linearly_to_the_next_sample() -> None:
    sim = ContactSim(Params(mu_s=1e3))
    sim.advance(0.0, [Touch(0.0, 0.0, 0.0)])
    st = sim.advance(0.01, [Touch(0.004, 0.004, 0.0)])
    assert st.touch_x == 0.004  # held at the last sample at the tick
    st = sim.advance(0.02, [Touch(0.03, 0.01, 0.0)])  # clamped to the tick, counted
    assert sim.clamped_samples == 1 and st.touch_x == 0.01
