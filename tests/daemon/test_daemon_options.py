"""One rule per option: the flag, the config file and the daemon refuse a value alike."""

from __future__ import annotations

from pathlib import Path

import pytest

from stiction.daemon.config import ConfigError, load_options
from stiction.daemon.options import RULES, Options, OptionsError, problem, validate

BAD = {
    "rate": 0,
    "clock": "wall",
    "hwm": 0,
    "substeps": 0,
    "late_threshold_ms": -1.0,
    "keepalive": -0.5,
    "spin_ms": 9.0,
    "realtime": 100,
}


def test_every_rule_has_a_bad_value_here() -> None:
    assert set(BAD) == set(RULES)


def test_defaults_pass() -> None:
    assert validate(Options()) == Options()


@pytest.mark.parametrize("name", sorted(BAD))
def test_validate_names_the_option_and_the_rule(name: str) -> None:
    opts = Options()
    setattr(opts, name, BAD[name])
    with pytest.raises(OptionsError) as caught:
        validate(opts)
    wrong = problem(name, BAD[name])
    assert wrong is not None and wrong.startswith(RULES[name][1])
    assert str(caught.value) == f"{name} {wrong}"


@pytest.mark.parametrize("name", ["rate", "clock", "hwm", "keepalive", "spin_ms", "realtime"])
def test_config_file_gives_the_same_words(name: str, tmp_path: Path) -> None:
    cfg = tmp_path / "c.toml"
    value = BAD[name]
    cfg.write_text(f"[daemon]\n{name} = {value!r}\n".replace("'", '"'))
    with pytest.raises(ConfigError) as caught:
        load_options(cfg)
    assert str(caught.value) == f"{cfg}:2: daemon.{name}: {problem(name, value)}"


def test_booleans_are_not_numbers() -> None:
    assert problem("realtime", True) is not None
    assert problem("hwm", True) is not None
    assert problem("spin_ms", 0) is None


@pytest.mark.parametrize(
    ("table", "name", "value", "limit"),
    [
        ("daemon", "hwm", 2**31, "2147483647"),  # reached setsockopt: OverflowError, a hung daemon
        ("daemon", "keepalive", 1e300, "1e+09"),
        ("sim", "substeps", 10**8, "10000"),  # minutes per tick
    ],
)
def test_values_too_large_to_use_are_refused_with_the_limit(
    table: str, name: str, value: float, limit: str, tmp_path: Path
) -> None:
    wrong = problem(name, value)
    assert wrong is not None and limit in wrong
    cfg = tmp_path / "c.toml"
    cfg.write_text(f"[{table}]\n{name} = {value!r}\n")
    with pytest.raises(ConfigError) as caught:
        load_options(cfg)
    assert str(caught.value) == f"{cfg}:2: {table}.{name}: {wrong}"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        # each was refused only later, by the simulator, without file or line (or not at all)
        ('[sim]\nintegrator = "rk5"\n', ":2: sim.integrator: unknown integrator 'rk5'"),
        ("[sim]\nmu_s = 1e300\n", ":2: sim.mu_s: must be at most 100"),
        ("[sim]\nm = 1e308\n", ":2: sim.m: must be at most 1e+09"),
        ("[sim]\nk = 1e-300\n", ":2: sim.k: parameters k=1e-300"),
        ("[sim]\nmu_k = -1\n", ":2: sim.mu_k: parameter mu_k must be >= 0"),
    ],
)
def test_sim_defaults_are_checked_where_they_are_written(
    text: str, message: str, tmp_path: Path
) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    with pytest.raises(ConfigError) as caught:
        load_options(cfg)
    assert str(caught.value).startswith(f"{cfg}{message}")


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        # each was accepted and drew the pointer at 1e298 to 1e304 px
        ("gain = 1e300", ":3: devices[0].gain: must be at most 1000"),
        ("screen_area = [0, 0, 1e300, 1e300]", ":3: devices[0].screen_area: must be pixels"),
        ("surface_area_mm = [0, 0, 1e-300, 1e-300]", ":3: devices[0].surface_area_mm: must be"),
        ("size_mm = [1e-300, 1e-300]", ":3: devices[0].size_mm: must be [width, height] in mil"),
        ("surface_size = [20, 0.1]", ":3: devices[0].surface_size: must be [width, height] in me"),
    ],
)
def test_mapping_values_far_outside_any_tablet_or_display_are_refused(
    entry: str, message: str, tmp_path: Path
) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_text(f'[[devices]]\nspec = "synthetic:demo"\n{entry}\n')
    with pytest.raises(ConfigError) as caught:
        load_options(cfg)
    assert str(caught.value).startswith(f"{cfg}{message}")


def test_a_tablet_sized_mapping_still_loads(tmp_path: Path) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        '[[devices]]\nspec = "synthetic:demo"\nsize_mm = [254, 158.8]\n'
        "surface_area_mm = [10, 10, 100, 50]\nscreen_area = [0, 0, 1920, 1080]\ngain = 2\n"
    )
    (device,) = load_options(cfg).devices
    assert device.surface_size == pytest.approx((0.254, 0.1588))
    assert device.mapping.gain == 2.0
