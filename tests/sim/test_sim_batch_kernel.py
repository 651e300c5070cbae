"""BatchSim compiled (numba) against the numpy test oracle, the interpreted step and ContactSim."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy_batch_oracle import NumpyBatchOracle

from stiction.drivers.sample import PenSample
from stiction.errors import ParamError
from stiction.sim import BatchSim, ContactSim, Params

pytest.importorskip("numba")


def _strokes(
    n: int, seed: int, ticks: int
) -> list[tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Random drags with pauses, late and same-instant ticks, lifts, hover and bad samples."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0, 0.1, (n, 2))
    vel = np.zeros((n, 2))
    out = []
    t = 0.0
    for k in range(ticks):
        t += 0.035 if k % 13 == 0 else (0.0 if k % 17 == 0 else 0.01)
        vel += rng.normal(0, 0.05, (n, 2)) * rng.integers(0, 2, (n, 1))
        vel[rng.uniform(size=n) < 0.1] = 0.0  # some touches held still
        pos += vel * 0.01
        tip = rng.uniform(size=n) > 0.05
        rng_in = rng.uniform(size=n) > 0.5
        x = pos[:, 0].copy()
        y = pos[:, 1].copy()
        x[rng.uniform(size=n) < 0.03] = np.nan
        y[rng.uniform(size=n) < 0.01] = np.inf
        out.append((t, x, y, tip, rng_in))
    return out


@settings(max_examples=40, deadline=None)
@given(
    st.integers(1, 40),
    st.floats(0.0, 2.0),
    st.floats(0.0, 1.0),
    st.integers(0, 2**32 - 1),
    st.sampled_from([1, 2, 3]),
)
def test_compiled_equals_numpy_and_contact_sim(
    n: int, mu_s: float, mu_k: float, seed: int, substeps: int
) -> None:
    p = Params(mu_s=mu_s, mu_k=mu_k)
    fast = BatchSim(n, p, substeps=substeps, compiled=True)
    slow = NumpyBatchOracle(n, p, substeps=substeps)
    sims = [ContactSim(p, substeps=substeps) for _ in range(n)]
    for k, (t, x, y, tip, rng_in) in enumerate(_strokes(n, seed, 70)):
        gain: float | np.ndarray = 1.0 if k < 30 else (1.3 if k < 50 else np.linspace(0.5, 1.5, n))
        fast.advance(t, x, y, tip, in_range=rng_in, load_gain=gain)
        slow.advance(t, x, y, tip, in_range=rng_in, load_gain=gain)
        assert np.array_equal(fast.mode, slow.mode)
        assert np.max(np.abs(fast.pointer - slow.pointer)) <= 1e-12
        assert np.max(np.abs(fast.touch - slow.touch)) <= 1e-12
        for i, sim in enumerate(sims):
            g = float(gain) if np.ndim(gain) == 0 else float(gain[i])  # type: ignore[index]
            sample = PenSample(t, x[i], y[i], tip=bool(tip[i]), in_range=bool(rng_in[i]))
            want = sim.advance(t, [sample], load_gain=g)
            got = fast.state(i)
            assert got.phase == want.phase
            assert abs(got.pointer_x - want.pointer_x) <= 1e-12
            assert abs(got.pointer_y - want.pointer_y) <= 1e-12
            assert abs(got.touch_x - want.touch_x) <= 1e-12
    assert fast.rejected_samples == slow.rejected_samples
    assert fast.rejected_samples == sum(s.rejected_samples for s in sims)
    assert fast.truncated_steps == slow.truncated_steps
    assert fast.event_overflows == slow.event_overflows


def test_long_gap_is_truncated_as_contact_sim_does() -> None:
    p = Params(mu_s=0.3, mu_k=0.1)
    fast = BatchSim(1, p, compiled=True)
    slow = NumpyBatchOracle(1, p)
    one = ContactSim(p)
    # A 30 s slow drag: more pieces than _BASE_PIECES allows, so the step is cut.
    for t, x in ((0.0, 0.0), (0.01, 0.05), (30.0, 0.35)):
        for b in (fast, slow):
            b.advance(t, [x], [0.0], [True])
        want = one.advance(t, [PenSample(t, x, 0.0, tip=True, in_range=True)])
    assert fast.truncated_steps == slow.truncated_steps == one.truncated_steps == 1
    for b in (fast, slow):
        got = b.state(0)
        assert got.phase == want.phase
        assert abs(got.pointer_x - want.pointer_x) <= 1e-12


def test_compiled_and_interpreted_take_the_same_steps() -> None:
    p = Params(mu_s=0.4, mu_k=0.2)
    for integrator in ("exact", "implicit-projection", "explicit-euler"):
        fast = BatchSim(6, p, integrator, compiled=True)
        slow = BatchSim(6, p, integrator, compiled=False)
        assert fast.compiled and not slow.compiled
        for t, x, y, tip, rng_in in _strokes(6, 7, 40):
            fast.advance(t, x, y, tip, in_range=rng_in)
            slow.advance(t, x, y, tip, in_range=rng_in)
        assert np.array_equal(fast.S, slow.S, equal_nan=True)


def test_rows_carry_their_own_material() -> None:
    """One batch, two materials: each row equals a ContactSim on its own material."""
    glue, ice = Params(mu_s=1.0, mu_k=0.3, k=0.2, C_l=1500.0), Params(mu_s=0.1, mu_k=0.05)
    b = BatchSim(4, glue)
    b.set_params(ice, rows=[1, 3])
    sims = [ContactSim(glue), ContactSim(ice), ContactSim(glue), ContactSim(ice)]
    for t, x, y, tip, rng_in in _strokes(4, 3, 60):
        b.advance(t, x, y, tip, in_range=rng_in)
        for i, sim in enumerate(sims):
            want = sim.advance(
                t, [PenSample(t, x[i], y[i], tip=bool(tip[i]), in_range=bool(rng_in[i]))]
            )
            got = b.state(i)
            assert got.phase == want.phase
            assert abs(got.pointer_x - want.pointer_x) <= 1e-12
            assert abs(got.string_px - want.string_px) <= 1e-9
    with pytest.raises(ParamError, match="rows"):
        b.set_params(ice, rows=[4])
