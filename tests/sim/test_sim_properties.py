"""Invariants of model.md over wide parameter and input ranges (hypothesis)."""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st
from sim_helpers import energy

from stiction.errors import ParamError
from stiction.sim import INTEGRATORS, BatchSim, ContactSim, Params, Touch

log_k = st.floats(-3.0, 4.0)
log_m = st.floats(-6.0, -2.0)
mu_s = st.one_of(st.sampled_from([0.0, 1e3]), st.floats(0.0, 3.0))
mu_k = st.one_of(st.just(0.0), st.floats(0.0, 2.0))
rates = st.sampled_from([60.0, 100.0, 133.0, 240.0, 1000.0])


@st.composite
def params(draw: st.DrawFn) -> Params:
    return Params(
        k=10 ** draw(log_k),
        m=10 ** draw(log_m),
        mu_s=draw(mu_s),
        mu_k=draw(mu_k),
        rate=draw(rates),
    )


@st.composite
def strokes(draw: st.DrawFn, lifts: bool = True) -> list[Touch]:
    """Irregularly timed samples: slow drags, fast flicks, jumps, pauses, lifts."""
    n = draw(st.integers(2, 60))
    t = draw(st.floats(-1e3, 1e3))
    x, y = draw(st.floats(-2.0, 2.0)), draw(st.floats(-2.0, 2.0))
    out = [Touch(t, x, y, True)]
    for _ in range(n):
        t += draw(st.sampled_from([0.0, 1e-4, 0.002, 0.005, 0.0075, 0.01, 0.03, 0.05]))
        scale = draw(st.sampled_from([0.0, 1e-6, 1e-4, 1e-3, 1e-2, 0.1, 1.0]))
        x += scale * draw(st.floats(-1.0, 1.0))
        y += scale * draw(st.floats(-1.0, 1.0))
        tip = draw(st.booleans()) if lifts and draw(st.integers(0, 9)) == 0 else True
        out.append(Touch(t, x, y, tip))
    return out


def run(sim: ContactSim, samples: list[Touch], hold: int = 0) -> list:
    """Tick at the sim's rate from the first sample, then hold for `hold` ticks."""
    dt = sim.params.dt
    t0 = samples[0].t
    end = samples[-1].t
    out = []
    i = 0
    k = 0
    while True:
        t = t0 + k * dt
        if t > end + hold * dt:
            break
        batch = []
        while i < len(samples) and samples[i].t <= t:
            batch.append(samples[i])
            i += 1
        out.append(sim.advance(t, batch))
        k += 1
    return out


def make(p: Params, integrator: str, substeps: int = 1) -> ContactSim:
    try:
        return ContactSim(p, integrator, substeps)
    except ParamError:
        assume(False)
        raise


@given(params(), strokes(), st.sampled_from(INTEGRATORS), st.sampled_from([1, 4]))
def test_outputs_finite_and_stick_bound_holds(
    p: Params, samples: list[Touch], integrator: str, substeps: int
) -> None:
    sim = make(p, integrator, substeps)
    for s in run(sim, samples, hold=20):
        assert all(
            math.isfinite(v) for v in (s.pointer_x, s.pointer_y, s.vx, s.vy, s.tension, s.string_px)
        )
        if s.phase == "stick":
            # "plus round-off": the stretch carries that of absolute coordinates.
            coords = abs(s.touch_x) + abs(s.touch_y) + abs(s.pointer_x) + abs(s.pointer_y)
            assert s.tension <= p.F_s * (1 + 1e-9) + p.k * 1e-15 * coords + 1e-300
            assert (s.vx, s.vy) == (0.0, 0.0)
        if s.phase in ("hover", "up"):
            assert (s.pointer_x, s.pointer_y) == (s.touch_x, s.touch_y)
    assert sim.event_overflows == 0


@given(params(), strokes(lifts=False), st.sampled_from(["exact", "implicit-projection"]))
def test_energy_never_increases_and_no_chatter_with_the_touch_held(
    p: Params, samples: list[Touch], integrator: str
) -> None:
    sim = make(p, integrator)
    states = run(sim, samples, hold=60)
    held = [s for s in states if s.t > samples[-1].t]
    assume(len(held) > 2)
    for a, b in itertools.pairwise(held):
        ea, eb = energy(sim, a), energy(sim, b)
        # Positions are absolute, so the stretch carries their round-off.
        d = 4e-16 * max(abs(b.touch_x), abs(b.touch_y), abs(b.pointer_x), abs(b.pointer_y))
        s = math.hypot(b.touch_x - b.pointer_x, b.touch_y - b.pointer_y)
        assert eb <= ea * (1 + 1e-9) + 2 * p.k * d * (2 * s + d) + 1e-300, (a, b)
        # At rest the phase only ever goes slip -> stick, never back (no chattering).
        assert not (a.phase == "stick" and b.phase == "slip")


@given(strokes(), st.sampled_from(["exact", "implicit-projection"]), st.floats(0.0, 3.0))
def test_no_blow_up_at_w_dt_100(samples: list[Touch], integrator: str, mu: float) -> None:
    p = Params(k=1e4, m=1e-4, mu_s=mu, mu_k=0.1)
    sim = make(p, integrator)
    xs = [s.x for s in samples]
    ys = [s.y for s in samples]
    # A critically damped pen kicked by a relative velocity V overshoots by at
    # most V/(w e); a reversal kicks by up to 2 vmax. Bounded by the input,
    # which is what "no blow-up" means.
    vmax = max(
        (math.hypot(b.x - a.x, b.y - a.y) / (b.t - a.t) for a, b in itertools.pairwise(samples)
         if b.t > a.t),
        default=0.0,
    )  # fmt: skip
    reach = (p.F_s + p.F_k) / p.k + 2 * vmax / (p.w * math.e) * (1 + 1e-9) + 1e-12
    if integrator == "implicit-projection":
        reach += vmax * p.dt  # first order: its overshoot may exceed the exact one by ~h v
    for s in run(sim, samples, hold=10):
        assert min(xs) - reach <= s.pointer_x <= max(xs) + reach
        assert min(ys) - reach <= s.pointer_y <= max(ys) + reach


@given(params(), strokes(lifts=False), st.sampled_from(INTEGRATORS), st.data())
def test_non_finite_input_never_touches_the_state(
    p: Params, samples: list[Touch], integrator: str, data: st.DataObject
) -> None:
    a = make(p, integrator)
    b = make(p, integrator)
    run(a, samples)
    run(b, samples)
    bad = data.draw(st.sampled_from([math.nan, math.inf, -math.inf]))
    where = data.draw(st.integers(0, 2))
    t = a.state.t + p.dt
    vals = [t, samples[-1].x, samples[-1].y]
    vals[where] = bad
    sa = a.advance(t, [Touch(vals[0], vals[1], vals[2], True)])
    sb = b.advance(t, [])
    assert sa == sb and a.rejected_samples == 1


@given(
    st.integers(1, 12),
    st.sampled_from(["exact", "implicit-projection", "explicit-euler", "semi-implicit-euler"]),
    st.floats(0.0, 2.0),
    st.floats(0.0, 1.0),
    st.integers(0, 2**32 - 1),
    st.sampled_from([1, 2]),
)
def test_batch_equals_contact_sim(
    n: int, integrator: str, mu_s: float, mu_k: float, seed: int, substeps: int
) -> None:
    p = Params(mu_s=mu_s, mu_k=mu_k)
    rng = np.random.default_rng(seed)
    batch = BatchSim(n, p, integrator, substeps)
    sims = [ContactSim(p, integrator, substeps) for _ in range(n)]
    pos = rng.uniform(0, 0.1, (n, 2))
    vel = np.zeros((n, 2))
    t = 0.0
    for k in range(60):
        t += 0.01 if k % 13 else 0.035  # some late ticks
        vel += rng.normal(0, 0.05, (n, 2)) * rng.integers(0, 2, (n, 1))
        pos += vel * 0.01
        tip = rng.uniform(size=n) > 0.05
        x = pos[:, 0].copy()
        x[rng.uniform(size=n) < 0.03] = np.nan
        gain = 1.0 if k < 30 else 1.3
        batch.advance(t, x, pos[:, 1], tip, load_gain=gain)
        for i, sim in enumerate(sims):
            want = sim.advance(t, [Touch(t, x[i], pos[i, 1], bool(tip[i]))], load_gain=gain)
            got = batch.state(i)
            assert got.phase == want.phase
            assert abs(got.pointer_x - want.pointer_x) <= 1e-12
            assert abs(got.pointer_y - want.pointer_y) <= 1e-12
    assert batch.rejected_samples == sum(s.rejected_samples for s in sims)
