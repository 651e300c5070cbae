"""Stroke builders and a tick driver shared by the simulator tests."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from stiction.sim import ContactSim, ContactState, Touch

Path2 = Callable[[float], tuple[float, float]]


def sampled(path: Path2, t0: float, t1: float, rate: float = 200.0) -> list[Touch]:
    n = round((t1 - t0) * rate)
    return [Touch(t0 + i / rate, *path(t0 + i / rate)) for i in range(n + 1)]


def drive(
    sim: ContactSim, samples: Sequence[Touch], t0: float, t1: float, dt: float = 0.01
) -> list[ContactState]:
    """Tick sim from t0 to t1 every dt, handing it the samples of each tick."""
    out = []
    i = 0
    n = round((t1 - t0) / dt)
    for k in range(n + 1):
        t = t0 + k * dt
        batch = []
        while i < len(samples) and samples[i].t <= t + 1e-12:
            batch.append(samples[i])
            i += 1
        out.append(sim.advance(t, batch))
    return out


def energy(sim: ContactSim, st: ContactState) -> float:
    p = sim.params
    sx = st.touch_x - st.pointer_x
    sy = st.touch_y - st.pointer_y
    return 0.5 * p.m * (st.vx**2 + st.vy**2) + 0.5 * p.k * (sx * sx + sy * sy)


def is_normal_or_zero(v: float) -> bool:
    return v == 0.0 or abs(v) >= 2.2250738585072014e-308 or not math.isfinite(v)
