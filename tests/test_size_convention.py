"""Sizes are typed in millimetres with the unit in the name, and a device without a
size is refused naming the flag or key of the command that met it (issue 13)."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from evdev import ecodes

from stiction import cli
from stiction.bench._device_storm import storm_pen
from stiction.daemon.config import load_options
from stiction.daemon.devices import DeviceConfig, open_source, parse_spec
from stiction.drivers.evdev.description import AbsAxis
from stiction.drivers.evdev.evemu import describe, write_events
from stiction.errors import SizeUnknown, StictionError

DAEMON_KEY = "size_mm = [width, height] in its [[devices]] entry of the stictiond config"


def unsized_evdev_recording(folder: Path) -> Path:
    """An evemu pen whose X/Y carry no resolution, on an id no table knows."""
    pen = storm_pen()
    axes = dict(pen.description.axes)
    for code in (ecodes.ABS_X, ecodes.ABS_Y):
        a = axes[code]
        axes[code] = AbsAxis(a.value, a.minimum, a.maximum)  # resolution 0
    desc = type(pen.description)(
        name="unsized pen", bustype=3, vendor=0x1D6B, product=0x5355, keys=pen.description.keys,
        axes=axes,
    )  # fmt: skip
    path = folder / "unsized.evemu"
    path.write_text(describe(desc) + write_events(pen.events))
    return path


def test_the_daemon_names_its_config_key(hid_data: Path, tmp_path: Path) -> None:
    for target in (hid_data / "huion-hs610.hid", unsized_evdev_recording(tmp_path)):
        spec = f"replay:{target}"
        with pytest.raises(SizeUnknown) as err:
            open_source(parse_spec(spec), DeviceConfig(spec), False, False).samples()
        assert DAEMON_KEY in str(err.value), err.value
        assert "--size" not in str(err.value)


@pytest.mark.parametrize("name", ["huion-hs610.hid", "unsized"])
def test_trace_names_its_flag_and_takes_millimetres(
    name: str, hid_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = unsized_evdev_recording(tmp_path) if name == "unsized" else hid_data / name
    out = tmp_path / "t.csv"
    assert cli.main(["trace", str(src), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--size-mm WxH (e.g. --size-mm 254x158.8)" in err and "Traceback" not in err
    assert cli.main(["trace", str(src), "--out", str(out), "--size-mm", "254x158.75"]) == 0
    assert out.stat().st_size > 0


@pytest.mark.parametrize("bad", ["254", "254x", "0x10", "-1x5", "nanx5", "1e9x5", "axb"])
def test_a_bad_size_is_refused_naming_the_flag(
    bad: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_:
        cli.main(["trace", "synthetic:demo", "--out", str(tmp_path / "t.csv"), f"--size-mm={bad}"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "--size-mm" in err and "WIDTHxHEIGHT in millimetres" in err


def config(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "stictiond.toml"
    path.write_text('[[devices]]\nspec = "/dev/input/event7"\n' + body)
    return path


def test_the_config_takes_millimetres_and_still_reads_the_old_metre_keys(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    new = load_options(
        config(tmp_path, "size_mm = [216, 135]\nsurface_area_mm = [10, 5, 100, 50]\n")
    )
    dev = new.devices[0]
    assert dev.surface_size == pytest.approx((0.216, 0.135))
    assert dev.mapping.surface_area == pytest.approx((0.01, 0.005, 0.1, 0.05))
    with caplog.at_level(logging.WARNING):
        old = load_options(config(tmp_path, "surface_size = [0.216, 0.135]\n"))
    assert old.devices[0].surface_size == pytest.approx((0.216, 0.135))
    assert "write size_mm in millimetres" in caplog.text
    with pytest.raises(StictionError, match=r"give size_mm \(millimetres\) or surface_size"):
        load_options(config(tmp_path, "size_mm = [216, 135]\nsurface_size = [0.2, 0.1]\n"))
    with pytest.raises(StictionError, match=r"devices\[0\]\.size_mm.*in millimetres"):
        load_options(config(tmp_path, "size_mm = [216000, 135]\n"))
