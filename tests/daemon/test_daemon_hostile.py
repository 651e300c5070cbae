"""Hostile control requests and scene files against a running daemon (issue 12).

Each test names the failure it guards against: a path that is not a regular
file blocking the tick loop, TOML of the wrong shape or nested thousands deep
escaping as a traceback, numbers the wire cannot carry being applied, and an
oversized request going unanswered. In every case the daemon must answer,
keep ticking and keep the scene it had.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest
import zmq
from daemon_support import ListSource, Runner, make_daemon, request, stroke
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stiction import protocol
from stiction.errors import SceneError
from stiction.scene.load import MAX_SCENE_BYTES, example_path, load_scene, parse_scene

DEEP = "a = " + "[" * 5000 + "]" * 5000 + "\n"
GOOD = '[scene]\nname = "ice"\noutside = "ice"\n[materials.ice]\nmu_s = 0.1\nmu_k = 0.05\n'


def _scene_name(ctx: zmq.Context[Any], ctl: str) -> str:
    return str(request(ctx, ctl, protocol.make_request("get_scene"))["scene"]["name"])


@pytest.fixture
def running(endpoints: tuple[str, str]):  # type: ignore[no-untyped-def]
    gate = threading.Event()
    d = make_daemon(endpoints, {"pen": ListSource(stroke(n=50), gate=gate)})
    with Runner(d):
        yield d, zmq.Context.instance(), endpoints[1]
        gate.set()


def test_set_scene_refuses_devices_and_fifos_without_reading_them(
    running: Any, tmp_path: Path
) -> None:
    d, ctx, ctl = running
    fifo = tmp_path / "scene.fifo"
    os.mkfifo(fifo)  # nobody writes: a blocking open or read would hang the daemon
    for path in ("/dev/zero", str(fifo), str(tmp_path)):
        reply = request(ctx, ctl, protocol.make_request("set_scene", path=path))
        assert reply is not None, f"no reply for {path}"
        assert reply["ok"] is False and "not a regular file" in reply["error"]
    assert _scene_name(ctx, ctl) == "default"
    ticks = d.schedule.ticks
    assert request(ctx, ctl, protocol.make_request("ping"))["ok"]
    assert d.schedule.ticks >= ticks


def test_a_scene_file_larger_than_the_limit_is_refused_unread(tmp_path: Path) -> None:
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * MAX_SCENE_BYTES + "\n")
    with pytest.raises(SceneError, match="at most"):
        load_scene(big)


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ('[[regions]]\nmaterial = "x"\nshape = ["rect"]\n', "regions[0].shape"),
        ("[scene]\neffects = [{a = 1}]\n", "scene.effects"),
        ("[scene]\ndisplay = [99999999999999999999, 1]\n", "scene.display"),
        ("[materials.m]\nmu_s = 0.5\nmu_k = 0.1\nk = 1e300\n", "materials.m.k"),
        ("[materials.m]\nmu_s = 1e308\nmu_k = 0.1\n", "materials.m.mu_s"),
        (DEEP, "nested too deeply"),
    ],
)
def test_set_scene_with_wrong_types_huge_numbers_or_deep_nesting_is_one_error(
    running: Any, text: str, where: str
) -> None:
    _, ctx, ctl = running
    reply = request(ctx, ctl, protocol.make_request("set_scene", toml=text))
    assert reply["ok"] is False and where in reply["error"]
    assert not reply["error"].startswith("internal error")
    assert _scene_name(ctx, ctl) == "default"
    snap = request(ctx, ctl, protocol.make_request("snapshot"))
    assert snap["ok"] and snap["scene"]["name"] == "default"


@pytest.mark.parametrize("value", [2**63, 1e300, -(2**62), float("inf")])
def test_set_params_refuses_numbers_out_of_range_and_keeps_going(running: Any, value: Any) -> None:
    _, ctx, ctl = running
    reply = request(ctx, ctl, protocol.make_request("set_params", k=value))
    assert reply["ok"] is False and "parameter k" in reply["error"]
    assert request(ctx, ctl, protocol.make_request("get_params"))["ok"]
    assert request(ctx, ctl, protocol.make_request("snapshot"))["ok"]


@pytest.mark.parametrize(
    ("path", "words"),
    [
        ("scene\x00.toml", "NUL byte"),  # os.open raised ValueError: an "internal error"
        ("s" * 100_000, "(100000 characters)"),  # the reply and the log repeated all of it
        ("", "empty"),  # Path("") is ".", so the reply spoke of a directory nobody named
    ],
)
def test_set_scene_with_an_impossible_path_is_one_short_error(
    running: Any, path: str, words: str
) -> None:
    d, ctx, ctl = running
    reply = request(ctx, ctl, protocol.make_request("set_scene", path=path))
    assert reply["ok"] is False and words in reply["error"], reply
    assert not reply["error"].startswith("internal error")
    assert len(reply["error"]) < 400
    assert d.control.errors == 1
    assert _scene_name(ctx, ctl) == "default"


@pytest.mark.parametrize(
    "args",
    [{"m" * 100_000: 1.0}, {"k": "9" * 100_000}, {"k": 1.0, "material": "m" * 100_000}],
)
def test_set_params_with_huge_names_or_values_is_one_short_error(
    running: Any, args: dict[str, Any]
) -> None:
    d, ctx, ctl = running
    reply = request(ctx, ctl, protocol.make_request("set_params", **args))
    assert reply["ok"] is False and "characters)" in reply["error"], reply["error"][:200]
    assert len(reply["error"]) < 400
    assert d.control.errors == 1


@pytest.mark.parametrize(
    "request_args",
    [
        {"op": "set_params", "k": 1e4},
        {"op": "set_params", "k": 1e4, "material": "standard"},
        {"op": "set_scene", "toml": GOOD + "k = 1e4\n"},
    ],
)
def test_a_change_the_integrator_cannot_step_is_refused_and_the_loop_keeps_ticking(
    endpoints: tuple[str, str], request_args: dict[str, Any]
) -> None:
    """explicit-euler with k = 1e4 was accepted (ok: true) and then failed every tick."""
    gate = threading.Event()
    d = make_daemon(
        endpoints,
        {"pen": ListSource(stroke(n=50), gate=gate)},
        integrator="explicit-euler",
    )
    ctx, ctl = zmq.Context.instance(), endpoints[1]
    with Runner(d):
        args = dict(request_args)
        reply = request(ctx, ctl, protocol.make_request(args.pop("op"), **args))
        assert reply["ok"] is False and "explicit-euler is unstable" in reply["error"]
        assert _scene_name(ctx, ctl) == "default"
        params = request(ctx, ctl, protocol.make_request("get_params"))["params"]
        assert params["k"] == 0.1
        assert d.control is not None and d.control.errors == 1
        gate.set()  # the pen draws on the scene that was kept: every tick steps cleanly
        for _ in range(2000):
            pen = request(ctx, ctl, protocol.make_request("stats"))["stats"]["devices"]["test-pen"]
            if pen["samples"] >= 50:
                break
        assert pen["samples"] >= 50 and pen["errors"] == 0, pen


def test_stictiond_with_a_scene_its_integrator_cannot_step_exits_2(tmp_path: Path) -> None:
    scene = tmp_path / "stiff.toml"
    scene.write_text(GOOD + "k = 1e4\n")
    argv = ["--scene", str(scene), "--integrator", "explicit-euler", "--device", "synthetic:demo"]
    _exits_2_in_words(tmp_path, argv, "explicit-euler is unstable")


def _exits_2_in_words(tmp_path: Path, argv: list[str], words: str) -> None:
    """stictiond with `argv` (on private endpoints) exits 2 saying `words`, no traceback."""
    argv = [*argv, "--pub", f"ipc://{tmp_path}/p", "--control", f"ipc://{tmp_path}/c"]
    done = subprocess.run(
        [sys.executable, "-m", "stiction.daemon.main", *argv],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2, done.stderr
    assert words in done.stderr and "Traceback" not in done.stderr


def test_an_unknown_op_of_a_megabyte_is_not_repeated_whole(running: Any) -> None:
    _, ctx, ctl = running
    reply = request(ctx, ctl, protocol.encode({"v": protocol.SCHEMA_VERSION, "op": "x" * 500_000}))
    assert reply["ok"] is False and "unknown op" in reply["error"]
    assert len(reply["error"]) < 1000


def _big_polygon(points: int) -> str:
    ring = ",".join(f"[{960 + i % 400}.5,{540 + i % 300}.5]" for i in range(points))
    return GOOD + f'[[regions]]\nshape = "polygon"\nmaterial = "ice"\npoints = [{ring}]\n'


def test_a_scene_too_large_for_the_wire_is_refused_and_the_old_one_kept(running: Any) -> None:
    """A 0.9 MB scene file (under MAX_SCENE_BYTES) was accepted; its get_scene reply
    (2 MB) and snapshot (1.1 MB) were then refused by every client as oversized."""
    _, ctx, ctl = running
    text = _big_polygon(55_000)
    assert len(text.encode()) < min(MAX_SCENE_BYTES, protocol.MAX_MESSAGE_BYTES)
    reply = request(ctx, ctl, protocol.make_request("set_scene", toml=text))
    assert reply["ok"] is False and "bytes; clients accept" in reply["error"], reply
    assert _scene_name(ctx, ctl) == "default"
    snap = request(ctx, ctl, protocol.make_request("snapshot"))
    assert snap["ok"] and snap["scene"]["name"] == "default"


def test_a_scene_that_fits_the_wire_is_served_whole(running: Any) -> None:
    _, ctx, ctl = running
    reply = request(ctx, ctl, protocol.make_request("set_scene", toml=_big_polygon(10_000)))
    assert reply["ok"] is True
    got = request(ctx, ctl, protocol.make_request("get_scene"))
    assert got["ok"] and len(got["scene"]["regions"][0]["points"]) == 10_000


def test_an_oversized_request_gets_a_reply_naming_the_limit(running: Any) -> None:
    d, ctx, ctl = running
    payload = protocol.make_request("set_scene", toml="#" * (2 * protocol.MAX_MESSAGE_BYTES))
    reply = request(ctx, ctl, payload)
    assert reply is not None, "an oversized request went unanswered"
    assert reply["ok"] is False and str(protocol.MAX_MESSAGE_BYTES) in reply["error"]
    reply = request(ctx, ctl, protocol.make_request("set_scene", toml=GOOD))
    assert reply["ok"] and reply["scene"]["name"] == "ice"
    assert d.control.errors == 1


def test_sighup_with_a_deeply_nested_scene_keeps_the_daemon_and_its_scene(tmp_path: Path) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text(GOOD)
    ctl = f"ipc://{tmp_path}/ctl"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "stiction.daemon.main",
            "--scene",
            str(scene),
            "--pub",
            f"ipc://{tmp_path}/pub",
            "--control",
            ctl,
            "--device",
            "synthetic:demo",
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    ctx = zmq.Context()
    try:
        assert request(ctx, ctl, protocol.make_request("ping"), 10_000)["ok"]
        for text in (DEEP, '[[regions]]\nshape = ["rect"]\n'):
            scene.write_text(text)
            before = request(ctx, ctl, protocol.make_request("stats"))["stats"]["reloads"]
            proc.send_signal(signal.SIGHUP)
            for _ in range(1000):
                stats = request(ctx, ctl, protocol.make_request("stats"))["stats"]
                if stats["reloads"] > before:
                    break
            else:
                raise AssertionError("the reload never finished")
            assert proc.poll() is None, "SIGHUP with a bad scene killed the daemon"
            assert _scene_name(ctx, ctl) == "ice"
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        ctx.term()
    err = proc.stderr.read() if proc.stderr else ""
    assert "nested too deeply" in err and "regions[0].shape" in err
    assert "Traceback" not in err


@pytest.mark.parametrize("text", [DEEP, '[[regions]]\nshape = ["rect"]\n'])
def test_stictiond_with_a_bad_scene_exits_2_in_one_line(tmp_path: Path, text: str) -> None:
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    done = subprocess.run(
        [sys.executable, "-m", "stiction.daemon.main", "--scene", str(scene)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert str(scene) in done.stderr


_EXAMPLES = [
    example_path(n).read_text("utf-8") for n in ("demo", "paper", "passthrough", "pressure")
]


@st.composite
def _mutated_scene(draw: st.DrawFn) -> str:
    """A shipped example with lines replaced by other TOML values of any type."""
    lines = draw(st.sampled_from(_EXAMPLES)).splitlines()
    values = st.sampled_from(
        ["[1]", "{a = 1}", '"x"', "true", "1e308", "-1", "99999999999999999999", "[[1, 2]]", "nan"]
    )
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        key, sep, _ = lines[i].partition("=")
        lines[i] = (
            f"{key}= {draw(values)}"
            if sep
            else draw(st.sampled_from(["[x]", "[[regions]]", lines[i]]))
        )
    return "\n".join(lines) + "\n"


@settings(max_examples=300)
@given(text=_mutated_scene())
def test_any_mutated_scene_is_a_scene_or_one_scene_error(text: str) -> None:
    try:
        parse_scene(text, "m.toml")
    except SceneError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("m.toml")


@settings(max_examples=200)
@given(text=st.text(max_size=300))
def test_any_text_is_a_scene_or_one_scene_error(text: str) -> None:
    with contextlib.suppress(SceneError):
        parse_scene(text, "t.toml")


def test_a_config_that_is_not_a_regular_file_is_refused_unread(tmp_path: Path) -> None:
    from stiction.daemon.config import ConfigError, load_options

    fifo = tmp_path / "stictiond.toml"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero"), tmp_path):
        with pytest.raises(ConfigError, match="not a regular file"):
            load_options(path)


@settings(max_examples=200)
@given(text=st.text(max_size=400))
def test_any_config_text_is_options_or_one_config_error(text: str) -> None:
    import tempfile

    from stiction.daemon.config import ConfigError, load_options

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "c.toml"
        path.write_text(text)
        try:
            load_options(path)
        except ConfigError as exc:
            assert "\n" not in str(exc).strip()


@settings(max_examples=200)
@given(text=st.text(max_size=400))
def test_any_device_table_overlay_is_a_table_or_one_device_error(text: str) -> None:
    from stiction.drivers.hid.devices import parse_table
    from stiction.errors import DeviceError

    with contextlib.suppress(DeviceError):
        parse_table(text, "overlay.toml")


@pytest.mark.parametrize("spec", ["/dev/null", "/dev/zero", "hidraw:/dev/null"])
def test_a_character_device_that_is_not_an_input_node_is_refused_at_start(spec: str) -> None:
    """/dev/null was taken as a device name and waited for forever; sysfs says it
    is a "mem" device (/sys/dev/char/1:3/subsystem)."""
    from stiction.daemon.devices import parse_spec, spec_problem

    problem = spec_problem(parse_spec(spec))
    assert problem is not None and spec.rpartition(":")[2] in problem
    assert "is a mem device, not an input device" in problem


_ANY_VALUE = st.recursive(
    st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(2**63), 2**64 - 1),
        st.floats(allow_nan=True, allow_infinity=True),
        st.text(max_size=40),
        st.binary(max_size=40),
        st.sampled_from(["", "a\x00b", ".", "/dev/zero", "/proc/self/mem", "-1e999"]),
    ),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=8,
)
_ARG_NAMES = ["mu_s", "mu_k", "k", "m", "g", "C_l", "rate", "material", "toml", "path", "x"]


@pytest.fixture
def idle_daemon(endpoints: tuple[str, str]):  # type: ignore[no-untyped-def]
    """An opened daemon whose loop does not run: requests go through its handler directly."""
    d = make_daemon(endpoints, {"pen": ListSource(stroke())})
    yield d
    d.close()


@settings(max_examples=300, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    op=st.sampled_from([*protocol.CONTROL_OPS, "nope"]),
    args=st.dictionaries(st.sampled_from(_ARG_NAMES), _ANY_VALUE, max_size=4),
)
def test_any_request_is_answered_in_words_and_leaves_a_working_scene(
    idle_daemon: Any, op: str, args: dict[str, Any]
) -> None:
    """Each request goes through the daemon's own handler (parse, prepare, apply); none may
    escape as an 'internal error', and whatever is in force afterwards still encodes."""
    d = idle_daemon
    assert d.control is not None
    reply = protocol.decode(d.control.handle(protocol.encode({"v": 1, "op": op, **args})))
    assert reply["ok"] is True or not str(reply["error"]).startswith("internal error"), reply
    protocol.encode(protocol.scene_message(d.scene_state.pipeline.wire(), 0))


@pytest.mark.parametrize("rate", ["1e-300", "0.001"])
def test_stictiond_at_a_rate_too_slow_to_stop_exits_2_in_one_line(
    tmp_path: Path, rate: str
) -> None:
    """1e-300 Hz was an OverflowError traceback from the clock's sleep; 0.001 Hz a daemon
    that slept through SIGTERM for 1000 s."""
    argv = ["--rate", rate, "--device", "synthetic:demo", "--seconds", "1"]
    _exits_2_in_words(tmp_path, argv, "rate must be >= 1 Hz")
