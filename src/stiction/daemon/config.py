"""The daemon's TOML config file, validated with file:line:key errors.

Flags override the file; the file overrides the built-in defaults. Relative
paths in the file (scene, keys) are relative to the file, so a config and
its scene can be moved together.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

from stiction.argtypes import check_endpoint
from stiction.daemon.devices import DeviceConfig, backend_problem, parse_spec, spec_problem
from stiction.daemon.mapping import ASPECTS, MODES, ROTATIONS, MappingConfig
from stiction.daemon.options import Options, problem
from stiction.daemon.security import CurveConfig
from stiction.drivers.sample import MAX_SURFACE_M, MIN_SURFACE_M
from stiction.errors import ParamError, StictionError
from stiction.scene.load import MAX_DISPLAY_PX, MAX_FRICTION, MAX_NUMBER
from stiction.sim.integrators import INTEGRATORS
from stiction.sim.params import Params
from stiction.tomlcheck import FieldPath, TomlReader
from stiction.userfiles import read_regular_text

log = logging.getLogger(__name__)


class ConfigError(StictionError):
    """A config file that cannot be used; the message names file, line and key."""


_DAEMON_KEYS = {
    "rate",
    "clock",
    "pub",
    "control",
    "scene",
    "display",
    "hwm",
    "late_threshold_ms",
    "hotplug",
    "keepalive",
    "spin_ms",
    "realtime",
}
_FLOATS = {"rate", "late_threshold_ms", "keepalive", "spin_ms"}
"""Number options a TOML integer may give: stored as float, as the flags store them."""
_SIM_KEYS = {"integrator", "substeps", "k", "m", "g", "mu_s", "mu_k", "C_l"}
_CURVE_KEYS = {"secret_key", "authorized_keys", "required"}
_DEVICE_KEYS = {
    "spec",
    "mapping",
    "aspect",
    "rotate",
    "size_mm",
    "surface_area_mm",
    "surface_size",  # the old metre-valued names, still read
    "surface_area",
    "screen_area",
    "gain",
    "grab",
    "backend",
}


class _Reader(TomlReader):
    """The shared TOML checker plus the config's number and path rules."""

    def __init__(self, path: Path, text: str) -> None:
        super().__init__(path, text, ConfigError)
        self.file = path

    def number(self, value: Any, where: FieldPath, positive: bool = True) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(where, f"must be a number, got {value!r}")
        if not math.isfinite(value) or (positive and value <= 0):
            self.fail(where, f"must be a positive finite number, got {value!r}")
        return float(value)

    def numbers(self, value: Any, where: FieldPath, n: int) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != n:
            self.fail(where, f"must be an array of {n} numbers, got {value!r}")
        return tuple(self.number(v, where, positive=False) for v in value)

    def path(self, value: Any, where: FieldPath) -> Path:
        p = Path(self.string(value, where)).expanduser()
        return p if p.is_absolute() else (self.file.parent / p)


def load_options(path: Path, base: Options | None = None) -> Options:
    """Read a config file into Options (starting from `base`)."""
    # A regular file of at most 1 MiB: SIGHUP re-reads it on a reload worker,
    # and a FIFO or /dev/zero named as the config must not block or fill it.
    text = read_regular_text(path, 1 << 20, ConfigError, "config")
    r = _Reader(path, text)
    data = r.data
    r.table(data, (), {"daemon", "sim", "curve", "devices"})
    opts = base if base is not None else Options()
    opts.config_path = path

    d = r.table(data.get("daemon", {}), ("daemon",), _DAEMON_KEYS)
    for key in ("rate", "late_threshold_ms", "keepalive", "spin_ms"):
        if key in d:
            r.number(d[key], ("daemon", key), positive=False)
    for key in ("rate", "clock", "hwm", "late_threshold_ms", "keepalive", "spin_ms", "realtime"):
        if key in d:
            wrong = problem(key, d[key])
            if wrong is not None:
                r.fail(("daemon", key), wrong)
            setattr(opts, key, float(d[key]) if key in _FLOATS else d[key])
    for key in ("pub", "control"):
        if key in d:
            text = r.string(d[key], ("daemon", key))
            try:
                setattr(opts, key, check_endpoint(text))
            except ValueError as exc:
                r.fail(("daemon", key), str(exc))
    if "scene" in d:
        opts.scene = r.path(d["scene"], ("daemon", "scene"))
    if "display" in d:
        w, h = r.numbers(d["display"], ("daemon", "display"), 2)
        if w <= 0 or h <= 0 or w != int(w) or h != int(h):
            r.fail(("daemon", "display"), "must be [width, height] in whole pixels > 0")
        opts.display = (int(w), int(h))
    if "hotplug" in d:
        opts.hotplug = r.boolean(d["hotplug"], ("daemon", "hotplug"))

    s = r.table(data.get("sim", {}), ("sim",), _SIM_KEYS)
    if "integrator" in s:
        opts.integrator = r.string(s["integrator"], ("sim", "integrator"))
        if opts.integrator not in INTEGRATORS:  # else refused later, without file and line
            r.fail(
                ("sim", "integrator"),
                f"unknown integrator {opts.integrator!r}; known: {', '.join(INTEGRATORS)}",
            )
    if "substeps" in s:
        wrong = problem("substeps", s["substeps"])
        if wrong is not None:
            r.fail(("sim", "substeps"), wrong)
        opts.substeps = s["substeps"]
    opts.params = {
        k: r.number(v, ("sim", k), positive=k not in ("mu_s", "mu_k"))
        for k, v in s.items()
        if k not in ("integrator", "substeps")
    }
    # The bounds a scene file and set_params have, and the simulator's own
    # check, here too: else a bad default is refused later without its line.
    for k, v in opts.params.items():
        limit = MAX_FRICTION if k in ("mu_s", "mu_k") else MAX_NUMBER
        if abs(v) > limit:
            r.fail(("sim", k), f"must be at most {limit:g}, got {v:g}")
    try:
        Params.from_mapping(opts.params)
    except ParamError as exc:
        one = len(opts.params) == 1  # then the parameter at fault is known
        r.fail(("sim", next(iter(opts.params))) if one else ("sim",), str(exc))

    c = r.table(data.get("curve", {}), ("curve",), _CURVE_KEYS)
    required = c.get("required", False)
    if not isinstance(required, bool):
        r.fail(("curve", "required"), "must be true or false")
    opts.curve = CurveConfig(
        secret_key=r.path(c["secret_key"], ("curve", "secret_key")) if "secret_key" in c else None,
        authorized_keys=r.path(c["authorized_keys"], ("curve", "authorized_keys"))
        if "authorized_keys" in c
        else None,
        required=required,
    )

    devices = data.get("devices", [])
    if not isinstance(devices, list):
        r.fail(("devices",), "must be an array of [[devices]] tables")
    opts.devices = [_device(r, i, raw) for i, raw in enumerate(devices)]
    return opts


# A surface (or an area of one) 1 mm to 10 m a side, the bounds every size
# source is held to: smaller is a typo, and it scaled the pointer to 1e304 px.
MAX_GAIN = 1000.0
"""Relative mapping: a thousand screen widths per surface width is far past any use."""


def _surface_words(key: str, what: str) -> str:
    if key.endswith("_mm"):
        where = ", x and y within +-10000" if "x, y" in what else ""
        return f"must be {what} in millimetres, width and height 1 to 10000{where}"
    where = ", x and y within +-10" if "x, y" in what else ""
    return f"must be {what} in metres, width and height 0.001 to 10{where}"


def _gain(r: _Reader, value: Any, where: FieldPath) -> float:
    gain = r.number(value, where)
    if gain > MAX_GAIN:
        r.fail(where, f"must be at most {MAX_GAIN:g}, got {gain:g}")
    return gain


def _device(r: _Reader, index: int, raw: Any) -> DeviceConfig:
    where: FieldPath = ("devices", index)
    t = r.table(raw, where, _DEVICE_KEYS)
    if "spec" not in t:
        r.fail(where, 'missing \'spec\' (e.g. spec = "/dev/hidraw3" or "synthetic:demo")')
    if not isinstance(t["spec"], str):
        r.fail((*where, "spec"), f"must be a string, got {t['spec']!r}")
    try:
        spec = parse_spec(t["spec"])
        problem = spec_problem(spec)
    except StictionError as exc:
        r.fail((*where, "spec"), str(exc))
    if problem is not None:
        r.fail((*where, "spec"), problem)
    backend = t.get("backend")
    problem = backend_problem(spec, backend)
    if problem is not None:
        r.fail((*where, "backend"), problem)
    mode = t.get("mapping", "area")
    if mode == "absolute":
        mode = "area"
    if mode not in MODES:
        r.fail((*where, "mapping"), f"must be area, absolute or relative, got {mode!r}")
    aspect = t.get("aspect", "keep")
    if aspect not in ASPECTS:
        r.fail((*where, "aspect"), f"must be keep or stretch, got {aspect!r}")
    rotate = t.get("rotate", 0)
    if rotate not in ROTATIONS or isinstance(rotate, bool):
        r.fail((*where, "rotate"), f"must be 0, 90, 180 or 270, got {rotate!r}")

    def one_of(new: str, old: str) -> tuple[str, float] | None:
        """Which of a millimetre key and its old metre-valued name is given: (key, to metres)."""
        if new in t and old in t:
            r.fail((*where, old), f"give {new} (millimetres) or {old} (metres), not both")
        if new in t:
            return new, 1e-3
        if old in t:
            log.warning("config: %s is in metres and kept only for old files; write %s in "
                        "millimetres", ".".join(map(str, (*where, old))), new)  # fmt: skip
            return old, 1.0
        return None

    def rect(key: str, scale: float) -> tuple[float, float, float, float] | None:
        x, y, w, h = r.numbers(t[key], (*where, key), 4)
        if w <= 0 or h <= 0:
            r.fail((*where, key), "width and height must be positive")
        # Bounded like a display (pixels) or a tablet (metres): a width of 1e-300
        # or 1e300 put the pointer at 1e304 px.
        if key == "screen_area":
            if not all(abs(v) <= MAX_DISPLAY_PX for v in (x, y, w, h)) or min(w, h) < 1:
                r.fail((*where, key), f"must be pixels: x, y within +-{MAX_DISPLAY_PX}, "
                       f"width and height 1 to {MAX_DISPLAY_PX}")  # fmt: skip
        else:
            m = [v * scale for v in (x, y, w, h)]
            if not all(abs(v) <= MAX_SURFACE_M for v in m) or min(m[2:]) < MIN_SURFACE_M:
                r.fail((*where, key), _surface_words(key, "x, y, width and height"))
        return (x * scale, y * scale, w * scale, h * scale)

    size = None
    if given := one_of("size_mm", "surface_size"):
        key, scale = given
        sw, sh = (v * scale for v in r.numbers(t[key], (*where, key), 2))
        if not all(MIN_SURFACE_M <= v <= MAX_SURFACE_M for v in (sw, sh)):
            r.fail((*where, key), _surface_words(key, "[width, height]"))
        size = (sw, sh)
    area = one_of("surface_area_mm", "surface_area")
    grab = t.get("grab", False)
    if not isinstance(grab, bool):
        r.fail((*where, "grab"), "must be true or false")
    mapping = MappingConfig(
        mode=mode,
        aspect=aspect,
        rotate=int(rotate),
        surface_area=rect(*area) if area else None,
        screen_area=rect("screen_area", 1.0) if "screen_area" in t else None,
        gain=_gain(r, t["gain"], (*where, "gain")) if "gain" in t else 1.0,
    )
    mapping_given = "mapping" in t
    return DeviceConfig(
        spec=r.string(t["spec"], (*where, "spec")),
        mapping=mapping,
        mapping_given=mapping_given,
        surface_size=size,
        grab=grab,
        backend=backend,
    )
