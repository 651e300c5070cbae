from __future__ import annotations

import math
import re

import pytest

from stiction.errors import ParamError, StictionError
from stiction.sim import ContactSim, Params


def test_defaults_are_the_papers() -> None:
    p = Params()
    assert (p.k, p.g, p.mu_k, p.C_l, p.rate) == (0.1, 9.8, 0.1, 2000.0, 100.0)
    assert p.c == pytest.approx(2 * math.sqrt(p.m * p.k))
    assert p.dt == 0.01
    assert p.F_s == pytest.approx(p.mu_s * p.m * p.g)
    assert p.F_k == pytest.approx(p.mu_k * p.m * p.g)


@pytest.mark.parametrize("name", ["k", "m", "g", "C_l", "rate"])
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf, -math.inf])
def test_bad_values_are_refused_naming_the_parameter(name: str, bad: float) -> None:
    with pytest.raises(ParamError, match=rf"\b{name}\b"):
        Params(**{name: bad})


@pytest.mark.parametrize("name", ["mu_s", "mu_k"])
def test_friction_may_be_zero_but_not_negative(name: str) -> None:
    assert getattr(Params(**{name: 0.0}), name) == 0.0
    with pytest.raises(ParamError, match=name):
        Params(**{name: -0.1})
    with pytest.raises(ParamError, match=name):
        Params(**{name: math.nan})


def test_replace_and_from_mapping_validate() -> None:
    assert Params().replace(mu_s=0.3).mu_s == 0.3
    with pytest.raises(ParamError, match="k"):
        Params().replace(k=0)
    with pytest.raises(ParamError, match="unknown parameter 'q'"):
        Params().replace(q=1)
    assert Params.from_mapping({"k": "0.5", "mu_s": 1}).k == 0.5
    with pytest.raises(ParamError, match="mu_s must be a number"):
        Params.from_mapping({"mu_s": "lots"})
    with pytest.raises(ParamError, match="unknown parameter 'kk'"):
        Params.from_mapping({"kk": 1})
    with pytest.raises(ParamError, match="m must be a number"):
        Params(m=True)


def test_param_error_is_a_stiction_error() -> None:
    assert issubclass(ParamError, StictionError)


def test_integrator_and_substeps_are_checked() -> None:
    with pytest.raises(ParamError, match="unknown integrator 'verlet'"):
        ContactSim(Params(), "verlet")
    with pytest.raises(ParamError, match="substeps"):
        ContactSim(Params(), "rk4", 0)


@pytest.mark.parametrize("name", ["explicit-euler", "semi-implicit-euler", "rk4"])
def test_unstable_fixed_step_is_refused_with_the_substeps_that_work(name: str) -> None:
    stiff = Params(k=1e4, m=1e-4)  # w*dt = 100
    with pytest.raises(ParamError, match=r"substeps >= (\d+)") as info:
        ContactSim(stiff, name)
    m = re.search(r"substeps >= (\d+)", str(info.value))
    assert m is not None
    need = int(m.group(1))
    ContactSim(stiff, name, substeps=need)  # that many is accepted ...
    with pytest.raises(ParamError):
        ContactSim(stiff, name, substeps=need - 1)  # ... and it is the fewest
    if name == "explicit-euler":
        assert need == 51  # |1 - w h| < 1  <=>  w h < 2
    for stable in ("exact", "implicit-projection", "default"):
        ContactSim(stiff, stable)


@pytest.mark.parametrize(
    "values",
    [{"k": 1e-300}, {"m": 1e300}, {"g": 1e300}, {"mu_s": 1e300}, {"k": 1e300, "m": 1e-300}],
)
def test_values_whose_derived_quantities_overflow_are_refused(values: dict[str, float]) -> None:
    with pytest.raises(ParamError, match="out of the range"):
        Params(**values)


def test_absurd_rates_are_refused() -> None:
    with pytest.raises(ParamError, match="rate must be <= 1e"):
        Params(rate=1e300)
    assert Params(rate=1e6).dt == 1e-6
    # a daemon sleeps to each deadline: at 1e-3 Hz it ignored SIGTERM for 1000 s,
    # at 1e-300 Hz its sleep overflowed time_t
    for slow in (0.999, 1e-3, 1e-300):
        with pytest.raises(ParamError, match="rate must be >= 1 Hz"):
            Params(rate=slow)
    assert Params(rate=1.0).dt == 1.0
