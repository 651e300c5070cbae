"""The daemon's options and the one place their values are checked.

The command line (daemon/main.py), the config file (daemon/config.py) and a
reload all end in an `Options`; every range rule lives in `RULES`, so a value
is refused with the same words wherever it came from: the config file puts
its file:line:key in front, `validate` (run by the daemon before it opens
anything) puts the option's name. Nothing here imports the loop, so the
config reader and the loop both import this module and not each other.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from stiction import protocol
from stiction.argtypes import MAX_HWM, MAX_SECONDS
from stiction.daemon.devices import DeviceConfig
from stiction.daemon.security import CurveConfig
from stiction.errors import StictionError
from stiction.scene.load import DEFAULT_DISPLAY
from stiction.sim.integrators import MAX_SUBSTEPS

CLOCKS = ("real", "virtual")
MAX_SPIN_MS = 5.0
"""Longer than this and the spin would eat a large part of a 100 Hz period."""


@dataclass
class Options:
    """Everything the daemon is configured with (config file and flags merged)."""

    rate: float = 100.0
    clock: str = "real"
    pub: str = protocol.DEFAULT_PUB
    control: str = protocol.DEFAULT_CONTROL
    scene: Path | None = None
    display: tuple[int, int] = DEFAULT_DISPLAY
    devices: list[DeviceConfig] = field(default_factory=list)
    params: dict[str, float] = field(default_factory=dict)
    integrator: str = "default"
    substeps: int = 1
    hwm: int = 1000
    late_threshold_ms: float | None = None
    seconds: float | None = None
    wait_subscribers: int = 0
    """Virtual clock: hold the first tick until this many subscriptions arrived."""
    wait_timeout: float = 30.0
    curve: CurveConfig = field(default_factory=CurveConfig)
    hotplug: bool = True
    config_path: Path | None = None
    scene_from_flag: bool = False
    stats_window: int = 10_000
    """Ticks kept for the jitter/latency percentiles of the stats reply."""
    keepalive: float = 1.0
    """While nothing happens, run one tick (a frame per device) every this
    many seconds instead of every period; 0 never idles."""
    spin_ms: float = 0.3
    """Sleep to this long before each deadline, then poll the clock (RealClock)."""
    start: float | None = None
    """Monotonic time of deadline 0 (real clock); default 10 ms after run()
    starts. Processes that share CLOCK_MONOTONIC can share a grid."""
    realtime: int = 0
    """SCHED_FIFO priority (1-99) for the loop thread; 0: ordinary scheduling."""


class OptionsError(StictionError):
    """An option value out of its range; the message names the option."""


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _whole(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


Rule = Callable[[Any], bool]

RULES: dict[str, tuple[Rule, str]] = {
    "rate": (lambda v: _number(v) and v > 0, "must be a positive finite number"),
    "clock": (lambda v: v in CLOCKS, "must be 'real' or 'virtual'"),
    "hwm": (
        lambda v: _whole(v) and 1 <= v <= MAX_HWM,
        f"must be a whole number of messages, 1 to {MAX_HWM}",
    ),
    "substeps": (
        lambda v: _whole(v) and 1 <= v <= MAX_SUBSTEPS,
        f"must be a whole number from 1 to {MAX_SUBSTEPS}",
    ),
    "late_threshold_ms": (
        lambda v: v is None or (_number(v) and v > 0),
        "must be a positive finite number",
    ),
    "keepalive": (
        lambda v: _number(v) and 0 <= v <= MAX_SECONDS,
        f"must be 0 (every tick) or more seconds, at most {MAX_SECONDS:g}",
    ),
    "spin_ms": (
        lambda v: _number(v) and 0 <= v <= MAX_SPIN_MS,
        f"must be from 0 to {MAX_SPIN_MS:g} (milliseconds)",
    ),
    "realtime": (lambda v: _whole(v) and 0 <= v <= 99, "must be a priority 1-99 (0: off)"),
}
"""Option name -> (accepts the value, what an accepted value is)."""


def problem(name: str, value: Any) -> str | None:
    """What is wrong with `value` for option `name` ("must be ..., got X"); None if fine."""
    rule = RULES.get(name)
    if rule is None or rule[0](value):
        return None
    shown = f"{value:g}" if _number(value) and not _whole(value) else repr(value)
    return f"{rule[1]}, got {shown}"


def validate(opts: Options) -> Options:
    """Refuse an Options with any value out of its range (the first one found)."""
    for name in RULES:
        wrong = problem(name, getattr(opts, name))
        if wrong is not None:
            raise OptionsError(f"{name} {wrong}")
    return opts
