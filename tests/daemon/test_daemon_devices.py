"""Device specs, the per-device clock map, and handing samples to ticks."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from stiction.daemon.devices import (
    ClockMap,
    DeviceConfig,
    DeviceSlot,
    Spec,
    parse_spec,
    take_live,
)
from stiction.drivers.sample import PenSample
from stiction.errors import StictionError


@pytest.mark.parametrize(
    ("text", "spec"),
    [
        ("synthetic:demo", Spec("synthetic", "demo")),
        ("synthetic:", Spec("synthetic", "demo")),
        ("replay:/x/a.hid", Spec("replay", "/x/a.hid")),
        ("replay:a.desc,b.events", Spec("replay", "a.desc", "b.events")),
        ("/dev/hidraw3", Spec("hidraw", "/dev/hidraw3")),
        ("/dev/input/event7", Spec("evdev", "/dev/input/event7")),
        ("256C:006D", Spec("vidpid", "256c:006d")),
        ("hid:256c:006d", Spec("vidpid", "256c:006d", backend="hidraw")),
        ("hidraw:256C:006D", Spec("vidpid", "256c:006d", backend="hidraw")),
        ("hidraw:/dev/hidraw3", Spec("hidraw", "/dev/hidraw3")),
        ("evdev:/dev/input/event2", Spec("evdev", "/dev/input/event2")),
        ("evdev:056a:0374", Spec("vidpid", "056a:0374", backend="evdev")),
        ("evdev:name:Wacom Intuos", Spec("name", "Wacom Intuos", backend="evdev")),
        ("hidraw:name:Huion", Spec("name", "Huion", backend="hidraw")),
        ("Wacom Intuos", Spec("name", "Wacom Intuos")),
        ("name:huion", Spec("name", "huion")),
    ],
)
def test_specs(text: str, spec: Spec) -> None:
    assert parse_spec(text) == spec


@pytest.mark.parametrize("text", ["", "  ", "replay:"])
def test_bad_specs(text: str) -> None:
    with pytest.raises(StictionError):
        parse_spec(text)


def test_clock_map_takes_the_fastest_delivery_and_relearns_a_step() -> None:
    c = ClockMap()
    c.observe(10.0, 110.004)
    c.observe(10.01, 110.012)  # faster delivery: offset shrinks to 100.002
    assert c.offset == pytest.approx(100.002)
    c.observe(10.02, 110.030)  # a slow one only creeps
    assert c.offset == pytest.approx(100.002 + 0.008e-3)
    c.observe(50.0, 110.04)  # the device clock jumped (e.g. wall clock set)
    assert c.offset == pytest.approx(60.04)
    assert c.steps == 1


def _slot() -> DeviceSlot:
    return DeviceSlot(config=DeviceConfig("x"), spec=Spec("name", "x"), name="x")


def test_take_live_holds_back_samples_after_the_tick_and_never_loses_one() -> None:
    slot = _slot()
    for i in range(6):  # device time 0..0.05, all delivered 1 ms later at loop 100+
        slot.queue.append((PenSample(t=i * 0.01, x=0.0, y=0.0, tip=True), 100.001 + i * 0.01))
    first, newest = take_live(slot, 99.99, 100.025)
    assert [round(s.t, 6) for s in first] == [100.001, 100.011, 100.021]
    assert newest == pytest.approx(100.021)
    second, _ = take_live(slot, 100.025, 100.1)
    assert len(second) == 3 and slot.samples == 6


def test_take_live_rejects_non_finite_samples_and_keeps_time_order() -> None:
    slot = _slot()
    slot.queue.append((PenSample(t=0.0, x=math.nan, y=0.0, tip=True), 1.0))
    slot.queue.append((PenSample(t=0.0, x=0.0, y=0.0, tip=True), 1.0))
    slot.queue.append((PenSample(t=math.inf, x=0.0, y=0.0, tip=True), 1.0))
    got, _ = take_live(slot, 0.5, 1.5)
    assert len(got) == 1 and slot.rejected == 2
    # a sample mapped before the previous tick is placed just after it
    slot.queue.append((PenSample(t=-1.0, x=0.0, y=0.0, tip=True), 1.0))
    got, _ = take_live(slot, 1.5, 2.0)
    assert len(got) == 1 and 1.5 < got[0].t <= 2.0


def test_the_nth_device_of_a_name_gets_n_as_its_suffix(endpoints: tuple[str, str]) -> None:
    """protocol.md: A, B, A are named A, B, A#2 (not A#3, the position)."""
    from daemon_support import ListSource, make_daemon, stroke

    d = make_daemon(
        endpoints,
        {
            "/dev/input/event1": ListSource(stroke(n=3), name="A"),
            "/dev/input/event2": ListSource(stroke(n=3), name="B"),
            "/dev/input/event3": ListSource(stroke(n=3), name="A"),
            "/dev/input/event4": ListSource(stroke(n=3), name="A"),
        },
    )
    try:
        assert [s.name for s in d.slots] == ["A", "B", "A#2", "A#3"]
    finally:
        d.close()


def test_stats_leave_out_a_rate_not_measured_yet(endpoints: tuple[str, str]) -> None:
    """protocol.md: a statistic that is missing is absent, never a made-up 0.0."""
    from daemon_support import ListSource, make_daemon, stroke

    d = make_daemon(endpoints, {"/dev/input/event1": ListSource(stroke(n=3), name="A")})
    try:
        device = d.stats()["devices"]["A"]
        assert "rate_hz" not in device
        assert device["samples"] == 0
    finally:
        d.close()


@pytest.mark.parametrize(
    "text",
    [
        "/dev/input/event999",
        "/dev/hidraw99",
        "256c:006d",
        "hid:256c:006d",
        "evdev:256c:006d",
        "hidraw:name:Huion",
        "Wacom Intuos",
    ],
)
def test_specs_that_may_appear_later_are_not_problems(text: str) -> None:
    from stiction.daemon.devices import spec_problem

    assert spec_problem(parse_spec(text)) is None


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("/etc/passwd", "not a character device"),
        ("zz:12", "malformed VID:PID"),
        ("hid:zz:0001", "malformed VID:PID"),
        ("hidraw:zz:0001", "malformed VID:PID"),
        ("evdev:zz:0001", "not a path, VID:PID or name:TEXT after evdev:"),
        ("/tmp/no/such/device", "does not exist"),
        ("/dev/hidrawx/../nope", "does not exist"),
    ],
)
def test_specs_that_can_never_be_devices(text: str, words: str) -> None:
    from stiction.daemon.devices import spec_problem

    problem = spec_problem(parse_spec(text))
    assert problem is not None and words in problem


def test_a_device_not_present_yet_is_listed_as_waiting(endpoints: tuple[str, str]) -> None:
    from daemon_support import ListSource, make_daemon, stroke

    from stiction.errors import DeviceError

    d = make_daemon(
        endpoints,
        {
            "/dev/input/event999": DeviceError("no such node"),
            "/dev/input/event1": ListSource(stroke(n=3), name="A"),
        },
    )
    try:
        listed = {x["spec"]: x["state"] for x in d.devices()}
        assert listed["/dev/input/event999"] == "waiting"
        assert listed["/dev/input/event1"] != "waiting"  # opened once: open, then ended
        stats = d.stats()["devices"]["/dev/input/event999"]
        assert stats["state"] == "waiting" and stats["spec"] == "/dev/input/event999"
    finally:
        d.close()


def test_config_device_that_can_never_be_one_names_its_key(tmp_path: Path) -> None:
    from stiction.daemon.config import ConfigError, load_options

    cfg = tmp_path / "c.toml"
    cfg.write_text('[[devices]]\nspec = "zz:12"\n')
    with pytest.raises(ConfigError, match=r"c\.toml:2: devices\[0\]\.spec: malformed VID:PID"):
        load_options(cfg)


@pytest.mark.parametrize(
    ("spec", "backend", "words"),
    [
        ("256c:006d", '"usb"', "devices[0].backend: must be 'hidraw' or 'evdev', got 'usb'"),
        ("256c:006d", "3", "devices[0].backend: must be 'hidraw' or 'evdev', got 3"),
        ("/dev/hidraw3", '"evdev"', "devices[0].backend: /dev/hidraw3 is read through hidraw"),
        ("synthetic:demo", '"evdev"', "devices[0].backend: a synthetic: spec has no backend"),
        ("evdev:256c:006d", '"hidraw"', "the spec asks for evdev and the backend key for hidraw"),
    ],
)
def test_config_backend_that_cannot_apply_names_its_key(
    tmp_path: Path, spec: str, backend: str, words: str
) -> None:
    from stiction.daemon.config import ConfigError, load_options

    cfg = tmp_path / "c.toml"
    cfg.write_text(f'[[devices]]\nspec = "{spec}"\nbackend = {backend}\n')
    with pytest.raises(ConfigError) as err:
        load_options(cfg)
    assert words in str(err.value)
    assert str(err.value).startswith(f"{cfg}:3: ")


@pytest.mark.parametrize(
    ("spec", "backend"),
    [("256c:006d", "evdev"), ("name:Huion", "hidraw"), ("hidraw:256c:006d", "hidraw")],
)
def test_config_backend_is_kept(tmp_path: Path, spec: str, backend: str) -> None:
    from stiction.daemon.config import load_options

    cfg = tmp_path / "c.toml"
    cfg.write_text(f'[[devices]]\nspec = "{spec}"\nbackend = "{backend}"\n')
    assert load_options(cfg).devices[0].backend == backend
