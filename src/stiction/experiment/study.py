"""A study file: what a psychophysics experiment shows, in which order, and what it asks.

A study is a TOML file (docs/experiments.md, "Protocols") read into a frozen
`Study`. Every mistake is a `StudyError` naming the file and the field, and
unknown keys are errors, so a typo never silently runs the wrong experiment
on a participant. Two presets reproduce the paper's user studies:
``paper-study1`` and ``paper-study2`` (files in ``presets/``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stiction.errors import StictionError
from stiction.tomlcheck import FieldPath, TomlReader, format_path, unknown_key
from stiction.userfiles import read_regular_text

PRESET_DIR = Path(__file__).resolve().parent / "presets"
PRESETS = ("paper-study1", "paper-study2")
METHODS = ("2afc", "ratio")
FIRST_ORDERS = ("balanced", "always", "never")
BLOCK_ORDERS = ("counterbalanced", "fixed")
MAX_STUDY_BYTES = 1 << 20
MAX_TRIALS = 10_000

DEFAULT_PARAMS = {"k": 0.1, "mu_k": 0.1, "C_l": 2000.0, "m": 1e-4, "g": 9.8}
"""The paper's parameters (k = 0.1 N/m, mu_k = 0.1, C_l = 2000, g = 9.8; m as stiction's)."""
DEFAULT_STEPS = (-0.10, -0.05, -0.01, 0.01, 0.05, 0.10)
"""The paper's ratio buttons (User study 2, Task design)."""


class StudyError(StictionError):
    """A study file or preset that cannot be run; the message names file and field."""


@dataclass(frozen=True, slots=True)
class Study:
    name: str
    method: str
    repetitions: int
    seed: int
    instructions: str
    display: tuple[int, int]
    travel_px: float
    start_tolerance_px: float
    params: dict[str, float]
    standard_mu_s: float
    comparison_mu_s: tuple[float, ...]
    strings: tuple[bool, ...]
    comparison_first: str
    block_order: str
    question: str
    ratio_start: float = 1.0
    steps: tuple[float, ...] = DEFAULT_STEPS
    source: str = "<preset>"

    @property
    def trials_per_block(self) -> int:
        return len(self.comparison_mu_s) * self.repetitions

    @property
    def n_trials(self) -> int:
        return self.trials_per_block * len(self.strings)

    def with_repetitions(self, repetitions: int) -> Study:
        """The same study with fewer or more repetitions (quick pilots, tests)."""
        if repetitions < 1:
            raise StudyError(f"repetitions must be at least 1, got {repetitions}")
        changed = dataclasses.replace(self, repetitions=repetitions)
        if changed.n_trials > MAX_TRIALS:  # the bound a study file has, for --repetitions too
            raise StudyError(
                f"--repetitions {repetitions}: {changed.n_trials} trials; at most {MAX_TRIALS}"
            )
        return changed


_SCHEMA: dict[str, dict[str, tuple[type | tuple[type, ...], bool]]] = {
    # table -> key -> (type, required)
    "study": {
        "name": (str, False),
        "method": (str, True),
        "repetitions": (int, True),
        "seed": (int, False),
        "instructions": (str, False),
    },
    "task": {
        "display": (list, False),
        "travel_px": ((int, float), False),
        "start_tolerance_px": ((int, float), False),
    },
    "params": {k: ((int, float), False) for k in DEFAULT_PARAMS},
    "standard": {"mu_s": ((int, float), True)},
    "comparison": {"mu_s": (list, True)},
    "conditions": {"string": (list, False)},
    "order": {"comparison_first": (str, False), "blocks": (str, False)},
    "answer": {
        "question": (str, False),
        "start": ((int, float), False),
        "steps": (list, False),
    },
}
_REQUIRED_TABLES = ("study", "standard", "comparison")


class _FieldError(StudyError):
    """A StudyError about one field; parse_study adds the field's line to it."""

    def __init__(self, where: str, field: str | FieldPath, message: str) -> None:
        # "study.method" for the fixed names; a tuple where a part is the user's
        # key or an index, which a dotted string would split or quote wrongly
        path = tuple(field.split(".")) if isinstance(field, str) else field
        super().__init__(f"{where}: {format_path(path)}: {message}")
        self.field = path
        self.message = message


def _fail(where: str, field: str | FieldPath, message: str) -> StudyError:
    return _FieldError(where, field, message)


def _number(
    where: str, field: str | FieldPath, value: Any, *, lo: float, hi: float = math.inf
) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(where, field, f"must be a number, got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and lo <= v <= hi):
        bound = f"between {lo:g} and {hi:g}" if math.isfinite(hi) else f"at least {lo:g}"
        raise _fail(where, field, f"must be {bound}, got {value!r}")
    return v


def _check_shape(where: str, data: dict[str, Any]) -> None:
    for table, value in data.items():
        if table not in _SCHEMA:
            raise _fail(where, table, f"unknown table; expected one of {', '.join(_SCHEMA)}")
        if not isinstance(value, dict):
            raise _fail(where, table, "must be a table ([" + table + "])")
        keys = _SCHEMA[table]
        for key, item in value.items():
            if key not in keys:
                raise _fail(where, (table, key), unknown_key(key, keys))
            typ, _ = keys[key]
            if (isinstance(item, bool) and typ is not bool) or not isinstance(item, typ):
                kind = typ.__name__ if isinstance(typ, type) else "number"
                raise _fail(where, (table, key), f"must be a {kind}, got {item!r}")
        for key, (_, required) in keys.items():
            if required and key not in value:
                raise _fail(where, (table, key), "missing (required)")
    for table in _REQUIRED_TABLES:
        if table not in data:
            raise _fail(where, table, "missing table (required)")


def parse_study(text: str, where: str) -> Study:
    """A Study from TOML text; `where` names the file in error messages, with the
    line of the field at fault (tomlcheck, as scenes and the daemon's config)."""
    reader = TomlReader(where, text, StudyError)
    try:
        return _build(reader.data, where)
    except _FieldError as exc:
        raise StudyError(f"{reader.location(exc.field)}: {exc.message}") from None


def _build(data: dict[str, Any], where: str) -> Study:
    _check_shape(where, data)
    s, task = data["study"], data.get("task", {})
    params_in, answer = data.get("params", {}), data.get("answer", {})
    order = data.get("order", {})

    method = s["method"]
    if method not in METHODS:
        raise _fail(where, "study.method", f"must be one of {', '.join(METHODS)}, got {method!r}")
    reps = s["repetitions"]
    if not 1 <= reps <= MAX_TRIALS:
        raise _fail(where, "study.repetitions", f"must be between 1 and {MAX_TRIALS}, got {reps}")
    name = s.get("name") or Path(where).stem
    if not name.strip() or any(c in name for c in "\n\r,"):
        raise _fail(where, "study.name", f"must be one line without commas, got {name!r}")

    display = task.get("display", [1920, 1080])
    if (
        len(display) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) for v in display)
        or not all(16 <= v <= 16384 for v in display)
    ):
        raise _fail(where, "task.display", f"must be [width, height] in pixels, got {display!r}")
    travel = _number(where, "task.travel_px", task.get("travel_px", 70.0), lo=1.0, hi=4096.0)
    tol = task.get("start_tolerance_px", 40.0)
    tolerance = _number(where, "task.start_tolerance_px", tol, lo=1.0, hi=4096.0)

    params = dict(DEFAULT_PARAMS)
    for key, value in params_in.items():
        params[key] = _number(where, ("params", key), value, lo=0.0 if key == "mu_k" else 1e-12)

    standard = _number(where, "standard.mu_s", data["standard"]["mu_s"], lo=0.0, hi=10.0)
    comps_raw = data["comparison"]["mu_s"]
    if not comps_raw:
        raise _fail(where, "comparison.mu_s", "needs at least one value")
    comps = tuple(
        _number(where, ("comparison", "mu_s", i), v, lo=0.0, hi=10.0)
        for i, v in enumerate(comps_raw)
    )
    if len(set(comps)) != len(comps):
        raise _fail(where, "comparison.mu_s", f"has repeated values: {list(comps_raw)}")

    strings_raw = data.get("conditions", {}).get("string", [True])
    if not strings_raw or not all(isinstance(v, bool) for v in strings_raw):
        raise _fail(
            where, "conditions.string", f"must be a list of true/false, got {strings_raw!r}"
        )
    if len(set(strings_raw)) != len(strings_raw):
        raise _fail(where, "conditions.string", f"has repeated values: {strings_raw!r}")

    first = order.get("comparison_first", "balanced" if method == "2afc" else "never")
    if first not in FIRST_ORDERS:
        raise _fail(
            where,
            "order.comparison_first",
            f"must be one of {', '.join(FIRST_ORDERS)}, got {first!r}",
        )
    blocks = order.get("blocks", "counterbalanced")
    if blocks not in BLOCK_ORDERS:
        raise _fail(
            where, "order.blocks", f"must be one of {', '.join(BLOCK_ORDERS)}, got {blocks!r}"
        )

    if method == "2afc" and ("start" in answer or "steps" in answer):
        raise _fail(where, "answer", "start and steps belong to method 'ratio', not '2afc'")
    start = _number(where, "answer.start", answer.get("start", 1.0), lo=0.01, hi=100.0)
    steps_raw = answer.get("steps", list(DEFAULT_STEPS))
    steps = tuple(
        _number(where, ("answer", "steps", i), v, lo=-100.0, hi=100.0)
        for i, v in enumerate(steps_raw)
    )
    if method == "ratio" and (not steps or any(v == 0 for v in steps)):
        raise _fail(where, "answer.steps", f"must be non-zero numbers, got {steps_raw!r}")
    n_trials = len(comps) * reps * len(strings_raw)
    if n_trials > MAX_TRIALS:
        raise _fail(where, "study.repetitions", f"{n_trials} trials; at most {MAX_TRIALS}")
    default_q = (
        "Which surface felt more frictional?"
        if method == "2afc"
        else "How strong was the second surface's friction, relative to the first?"
    )
    return Study(
        name=name,
        method=method,
        repetitions=reps,
        seed=s.get("seed", 1),
        instructions=s.get("instructions", "").strip(),
        display=(display[0], display[1]),
        travel_px=travel,
        start_tolerance_px=tolerance,
        params=params,
        standard_mu_s=standard,
        comparison_mu_s=comps,
        strings=tuple(strings_raw),
        comparison_first=first,
        block_order=blocks,
        question=answer.get("question", default_q),
        ratio_start=start,
        steps=steps,
        source=where,
    )


def preset_path(name: str) -> Path:
    return PRESET_DIR / f"{name}.toml"


def load_study(spec: str | Path) -> Study:
    """A study from a preset name (paper-study1, paper-study2) or a TOML path."""
    text_spec = str(spec)
    if text_spec in PRESETS:
        path = preset_path(text_spec)
        return parse_study(path.read_text(encoding="utf-8"), text_spec)
    path = Path(spec)
    if not path.exists():
        raise StudyError(f"{spec}: no such study file (or preset; presets: {', '.join(PRESETS)})")
    text = read_regular_text(path, MAX_STUDY_BYTES, StudyError, "study file")
    return parse_study(text, str(path))
