"""Integrator names, the default, and the stability check for the fixed-step ones.

The explicit schemes are only conditionally stable; at stiff settings
(k = 1e4 N/m, w*dt = 100) explicit Euler multiplies the error by 99 per step.
Rather than let a pointer fly off to infinity a few ticks into a stroke, a
setting whose linear step matrix has spectral radius >= 1 is refused up front
with the substep count that would make it stable.
"""

from __future__ import annotations

import math

from stiction.errors import ParamError
from stiction.sim.params import Params

INTEGRATORS: tuple[str, ...] = (
    "explicit-euler",
    "semi-implicit-euler",
    "rk4",
    "implicit-projection",
    "exact",
    "default",
)
DEFAULT_INTEGRATOR = "exact"
"""What "default" resolves to; docs/accuracy.md explains the choice from the benchmark."""

_CONDITIONAL = ("explicit-euler", "semi-implicit-euler", "rk4")


def resolve(name: str) -> str:
    if name == "default":
        return DEFAULT_INTEGRATOR
    if name not in INTEGRATORS:
        raise ParamError(f"unknown integrator {name!r}; known: {', '.join(INTEGRATORS)}")
    return name


def spectral_radius(name: str, wh: float) -> float:
    """Spectral radius of one step of the critically damped oscillator, in units of w*h."""
    # State (x, v/w) so the matrix depends on wh only; J = [[0, 1], [-1, -2]] * wh.
    z = wh
    if name == "explicit-euler":
        m = ((1.0, z), (-z, 1.0 - 2.0 * z))
    elif name == "semi-implicit-euler":
        m = ((1.0 - z * z, z * (1.0 - 2.0 * z)), (-z, 1.0 - 2.0 * z))
    elif name == "rk4":
        j = ((0.0, z), (-z, -2.0 * z))
        m = _poly_exp(j)
    else:
        return 0.0
    tr = m[0][0] + m[1][1]
    det = m[0][0] * m[1][1] - m[0][1] * m[1][0]
    disc = tr * tr / 4.0 - det
    if disc >= 0.0:
        r = math.sqrt(disc)
        return max(abs(tr / 2.0 + r), abs(tr / 2.0 - r))
    return math.sqrt(max(det, 0.0))


def _mul(
    a: tuple[tuple[float, float], ...], b: tuple[tuple[float, float], ...]
) -> tuple[tuple[float, float], tuple[float, float]]:
    return (
        (a[0][0] * b[0][0] + a[0][1] * b[1][0], a[0][0] * b[0][1] + a[0][1] * b[1][1]),
        (a[1][0] * b[0][0] + a[1][1] * b[1][0], a[1][0] * b[0][1] + a[1][1] * b[1][1]),
    )


def _poly_exp(
    j: tuple[tuple[float, float], tuple[float, float]],
) -> tuple[tuple[float, float], tuple[float, float]]:
    """I + J + J^2/2 + J^3/6 + J^4/24: the RK4 step matrix for a linear system."""
    j2 = _mul(j, j)
    j3 = _mul(j2, j)
    j4 = _mul(j3, j)
    return tuple(  # type: ignore[return-value]
        tuple(
            (1.0 if r == c else 0.0) + j[r][c] + j2[r][c] / 2 + j3[r][c] / 6 + j4[r][c] / 24
            for c in range(2)
        )
        for r in range(2)
    )


MAX_SUBSTEPS = 10_000
"""Substeps per tick. 10,000 cost about 2.4 ms a tick for one contact (`stiction
simulate example:stroke --substeps 10000`: 0.88 s for its 360 ticks), a quarter
of the 10 ms period at 100 Hz; 1e8 took minutes a tick, a hang to its user. An
integrator that needs more is the wrong one: the default is stable at any step."""


def check_substeps(substeps: object) -> int:
    """The substep count both steppers accept: an integer from 1 to MAX_SUBSTEPS (not a bool)."""
    if (
        isinstance(substeps, bool)
        or not isinstance(substeps, int)
        or not 1 <= substeps <= MAX_SUBSTEPS
    ):
        raise ParamError(
            f"substeps must be an integer >= 1 and <= {MAX_SUBSTEPS}, got {substeps!r}"
        )
    return substeps


def checked_params(name: str, params: object, substeps: int) -> Params:
    """params, once it is a Params that integrator `name` is stable at."""
    if not isinstance(params, Params):
        raise ParamError(f"params must be a stiction.sim.Params, got {type(params).__name__}")
    check_stable(name, params, substeps)
    return params


def check_stable(name: str, params: Params, substeps: int) -> None:
    """Refuse a fixed-step integrator whose step would amplify errors."""
    if name not in _CONDITIONAL:
        return
    wh = params.w * params.dt / substeps
    if spectral_radius(name, wh) < 1.0:
        return
    need = substeps
    while spectral_radius(name, params.w * params.dt / need) >= 1.0 and need < 1 << 30:
        need *= 2
    lo = max(substeps, need // 2)
    while lo < need:
        mid = (lo + need) // 2
        if spectral_radius(name, params.w * params.dt / mid) < 1.0:
            need = mid
        else:
            lo = mid + 1
    raise ParamError(
        f"{name} is unstable at w*dt/substeps = {wh:.3g} (w = sqrt(k/m) = {params.w:.4g}/s, "
        f"rate {params.rate:g} Hz): use substeps >= {need}, or the default integrator, "
        "which is stable at any step"
    )
