"""BatchSim's own surface: lifecycle, accessors, refusals (equality is a property test)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stiction.drivers.sample import PenSample
from stiction.errors import ParamError
from stiction.sim import BatchSim, ContactSim, Params
from stiction.sim.batch import PHASE_CODES


def test_lifecycle_hover_up_and_accessors() -> None:
    b = BatchSim(3, Params())
    b.advance(0.0, [0.0, 0.1, 0.2], [0.0, 0.0, 0.0], [True, True, False], in_range=[1, 1, 1])
    assert [PHASE_CODES[c] for c in b.phase_codes] == ["stick", "stick", "hover"]
    b.advance(0.01, [0.05, 0.1, 0.25], [0.0, 0.0, 0.0], [True, False, False])
    assert [PHASE_CODES[c] for c in b.phase_codes] == ["slip", "up", "up"]
    assert b.pointer.shape == (2, 3) and b.touch.shape == (2, 3)
    assert b.touch[0, 2] == b.pointer[0, 2] == 0.25
    t = b.tension()
    assert t[1] == t[2] == 0.0 and t[0] == pytest.approx(b.state(0).tension)
    st = b.state(0)
    assert st.phase == "slip" and st.string_px > 0.0 and st.string_dir[0] > 0.99


def test_state_matches_contact_sim_with_pen_samples() -> None:
    p = Params(mu_s=0.3)
    b = BatchSim(1, p)
    c = ContactSim(p)
    for k in range(80):
        t = k * 0.01
        x, y = 0.02 * math.sin(3 * t), 0.01 * t
        tip = not 30 <= k < 35
        b.advance(t, [x], [y], [tip], in_range=[True])
        want = c.advance(t, [PenSample(t, x, y, tip=tip, in_range=True)])
        got = b.state(0)
        assert got.phase == want.phase
        assert got.pointer_x == pytest.approx(want.pointer_x, abs=1e-12)
        assert got.tension == pytest.approx(want.tension, abs=1e-12)


def test_non_finite_samples_hold_the_touch_and_are_counted() -> None:
    b = BatchSim(2, Params())
    b.advance(0.0, [0.0, 0.0], [0.0, 0.0], [True, True])
    b.advance(0.01, [math.nan, 0.001], [0.0, math.inf], [True, True])
    assert b.rejected_samples == 2
    assert np.all(b.touch == 0.0)


def test_refusals() -> None:
    with pytest.raises(ParamError, match="rk4 has no batch form"):
        BatchSim(4, Params(), "rk4")
    with pytest.raises(ParamError, match="only with the exact integrator"):
        BatchSim(4, Params(), "explicit-euler", events=True)
    with pytest.raises(ParamError, match="number of contacts"):
        BatchSim(0)
    with pytest.raises(ParamError, match="unstable"):
        BatchSim(4, Params(k=1e4), "explicit-euler")
    b = BatchSim(2, Params())
    b.advance(1.0, [0, 0], [0, 0], [True, True])
    with pytest.raises(ParamError, match="before the previous tick"):
        b.advance(0.5, [0, 0], [0, 0], [True, True])
    with pytest.raises(ParamError, match="finite"):
        b.advance(math.nan, [0, 0], [0, 0], [True, True])
    with pytest.raises(ParamError, match="load_gain"):
        b.advance(1.01, [0, 0], [0, 0], [True, True], load_gain=[1.0, -1.0])


def test_per_contact_load_gain_releases_only_the_lighter_contact() -> None:
    b = BatchSim(2, Params(mu_s=0.5))
    b.advance(0.0, [0.0, 0.0], [0.0, 0.0], [True, True])
    r = 0.5 * 1e-4 * 9.8 / 0.1  # stick radius at load 1
    b.advance(0.01, [0.8 * r, 0.8 * r], [0.0, 0.0], [True, True])
    b.advance(0.02, [0.8 * r, 0.8 * r], [0.0, 0.0], [True, True], load_gain=[1.0, 0.5])
    assert [PHASE_CODES[c] for c in b.phase_codes] == ["stick", "slip"]
