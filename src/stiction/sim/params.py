"""Model parameters, validated once so the integrators never see a bad value.

Every integrator divides by m, takes sqrt(k/m) and multiplies by the rate; a
zero, negative or non-finite value there would not fail loudly, it would turn
the pointer into NaN a few ticks later. So the check happens here, at the
boundary, with a message that names the parameter the user typed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from stiction.errors import ParamError

MAX_RATE = 1e6
"""Hz. Far above any display or tablet; beyond it steps become too short to resolve."""
MIN_RATE = 1.0
"""Hz. The daemon's loop sleeps to each tick's deadline and notices SIGTERM only
there: at 0.001 Hz stictiond ignored SIGTERM for 1000 s, and at 1e-300 Hz its
sleep overflowed time_t (an OverflowError traceback). Displays refresh at 24 Hz
and more, so a slower tick shows nothing a user could feel."""
# Parameters that may legitimately be zero (no static / no kinetic friction).
_MAY_BE_ZERO = frozenset({"mu_s", "mu_k"})
_UNITS = {
    "k": "N/m",
    "m": "kg",
    "g": "m/s^2",
    "mu_s": "",
    "mu_k": "",
    "C_l": "px/sqrt(N)",
    "rate": "Hz",
}


def _check(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParamError(f"parameter {name} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ParamError(f"parameter {name} must be finite, got {v!r}")
    if name in _MAY_BE_ZERO:
        if v < 0.0:
            raise ParamError(f"parameter {name} must be >= 0, got {v!r}")
    elif v <= 0.0:
        unit = f" {_UNITS[name]}" if _UNITS[name] else ""
        raise ParamError(f"parameter {name} must be > 0{unit}, got {v!r}")
    return v


@dataclass(frozen=True, slots=True)
class Params:
    """The constants of docs/design/model.md; defaults are the paper's (m is ours)."""

    k: float = 0.1
    m: float = 1.0e-4
    g: float = 9.8
    mu_s: float = 0.7
    mu_k: float = 0.1
    C_l: float = 2000.0
    rate: float = 100.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _check(f.name, getattr(self, f.name)))
        # Each value may be fine alone and still overflow what the integrators
        # compute from them (k = 1e-300 makes the stick radius squared infinite).
        if self.rate > MAX_RATE:
            raise ParamError(f"parameter rate must be <= {MAX_RATE:g} Hz, got {self.rate!r}")
        if self.rate < MIN_RATE:
            raise ParamError(f"parameter rate must be >= {MIN_RATE:g} Hz, got {self.rate!r}")
        derived: tuple[float, ...]
        try:
            derived = (
                self.c,
                self.w,
                self.w * self.w,
                self.F_s,
                self.F_k,
                (self.F_s / self.k) ** 2,
                self.F_k**2,
                self.C_l * math.sqrt(self.k),
            )
        except (OverflowError, ZeroDivisionError):
            derived = (math.inf,)
        if not all(math.isfinite(v) for v in derived) or self.w == 0.0:
            raise ParamError(
                f"parameters k={self.k!r}, m={self.m!r}, g={self.g!r}, mu_s={self.mu_s!r}, "
                f"mu_k={self.mu_k!r} are out of the range the simulator can compute with"
            )

    @property
    def c(self) -> float:
        """Critical damping: the paper wants no oscillation after release."""
        return 2.0 * math.sqrt(self.m * self.k)

    @property
    def w(self) -> float:
        """Natural angular frequency sqrt(k/m); w*dt is what makes a step stiff."""
        return math.sqrt(self.k / self.m)

    @property
    def dt(self) -> float:
        return 1.0 / self.rate

    @property
    def F_s(self) -> float:
        return self.mu_s * self.m * self.g

    @property
    def F_k(self) -> float:
        return self.mu_k * self.m * self.g

    def replace(self, **changes: Any) -> Params:
        unknown = set(changes) - set(names())
        if unknown:
            raise ParamError(_unknown_message(sorted(unknown)[0]))
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> Params:
        """Build from a mapping (a TOML table, parsed --param pairs); strings are parsed."""
        parsed: dict[str, Any] = {}
        for key, raw in values.items():
            if key not in names():
                raise ParamError(_unknown_message(key))
            value = raw
            if isinstance(raw, str):
                try:
                    value = float(raw.strip())
                except ValueError:
                    raise ParamError(f"parameter {key} must be a number, got {raw!r}") from None
            parsed[key] = value
        return cls(**parsed)


def names() -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(Params))


def _unknown_message(key: str) -> str:
    return f"unknown parameter {key!r}; known: {', '.join(names())}"


def check_tick(t: float, prev: float | None) -> float:
    """A tick time both steppers accept: finite and not before the previous tick."""
    t = float(t)
    if not math.isfinite(t):
        raise ParamError(f"tick time must be finite, got {t!r}")
    if prev is not None and t < prev:
        raise ParamError(f"tick time {t!r} is before the previous tick {prev!r}")
    return t
