"""stictiond as a process: flags, config, SIGHUP reload, SIGTERM stop, one-line errors."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zmq

from stiction import protocol
from stiction.daemon import main as daemon_main

SCENE = '[scene]\nname = "{name}"\noutside = "m"\n[materials.m]\nmu_s = 0.5\nmu_k = 0.1\n'


def _ask(ctx: zmq.Context[Any], endpoint: str, op: str, **args: Any) -> dict[str, Any]:
    req = ctx.socket(zmq.REQ)
    req.linger = 0
    req.connect(endpoint)
    try:
        req.send(protocol.make_request(op, **args))  # type: ignore[arg-type]
        assert req.poll(10_000), f"no reply to {op}"
        return dict(msgpack.unpackb(req.recv()))
    finally:
        req.close()


def _wait_stat(ctx: zmq.Context[Any], endpoint: str, key: str, value: int) -> dict[str, Any]:
    for _ in range(1000):  # each round trip waits for the daemon's next idle moment
        stats = _ask(ctx, endpoint, "stats")["stats"]
        if stats[key] >= value:
            return dict(stats)
    raise AssertionError(f"{key} never reached {value}")


def test_sighup_reloads_keeping_the_old_scene_when_bad_and_sigterm_stops(tmp_path: Path) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(name="first"))
    ctl = f"ipc://{tmp_path}/ctl"
    config = tmp_path / "stictiond.toml"
    config.write_text(
        f'[daemon]\nscene = "scene.toml"\npub = "ipc://{tmp_path}/pub"\ncontrol = "{ctl}"\n'
        "hotplug = false\n"
    )
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "stiction.daemon.main",
            "--config",
            str(config),
            "--device",
            "synthetic:demo",
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    ctx = zmq.Context()
    try:
        assert _ask(ctx, ctl, "get_scene")["scene"]["name"] == "first"
        scene.write_text(SCENE.format(name="second").replace("mu_s = 0.5", "mu_s = -2"))
        proc.send_signal(signal.SIGHUP)
        stats = _wait_stat(ctx, ctl, "reloads", 1)
        assert stats["scene_errors"] == 1
        assert _ask(ctx, ctl, "get_scene")["scene"]["name"] == "first"
        scene.write_text(SCENE.format(name="second"))
        proc.send_signal(signal.SIGHUP)
        _wait_stat(ctx, ctl, "reloads", 2)
        assert _ask(ctx, ctl, "get_scene")["scene"]["name"] == "second"
        assert _ask(ctx, ctl, "devices")["devices"][0]["state"] == "open"
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        ctx.term()
    err = proc.stderr.read() if proc.stderr else ""
    assert "reload_failed" in err and "scene.toml:5: materials.m.mu_s" in err
    assert "Traceback" not in err and "stopped ticks=" in err


def test_virtual_replay_exits_at_the_end_of_the_stream(evdev_data: Path, tmp_path: Path) -> None:
    rec = evdev_data / "wacom-cintiq-13hd-touch-pen.evemu"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "stiction.daemon.main",
            "--clock",
            "virtual",
            f"--device=replay:{rec}",
            "--pub",
            f"ipc://{tmp_path}/p",
            "--control",
            f"ipc://{tmp_path}/c",
            "--log-format",
            "json",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert '"event": "stopped"' in done.stderr


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--scene", "/no/such.toml"], "cannot read scene"),
        (["--device", "replay:/no/such.hid"], "no such recording"),
        (["--clock", "virtual", "--device", "/dev/hidraw99"], "--clock virtual needs replay"),
        (["--pub", "tcp://0.0.0.0:5556"], "needs CURVE keys"),
        (["--config", "/no/such/config.toml"], "cannot read config"),
        (["--device", "synthetic:nope"], "unknown synthetic stroke"),
        (["--device", "/etc/passwd"], "--device '/etc/passwd': /etc/passwd is not a character"),
        (["--device", "zz:12"], "--device 'zz:12': malformed VID:PID"),
        (["--device", "hid:12:3456"], "malformed VID:PID"),
        (["--device", "/no/such/node"], "does not exist and is not a /dev/input"),
        (["--keepalive", "-1"], "argument --keepalive: must not be negative"),
        (["--spin-ms", "9"], "spin_ms must be from 0 to 5"),
        (["--realtime", "150"], "argument --realtime: must be 0 to 99"),
    ],
)
def test_user_errors_are_one_line(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["--pub", f"ipc://{tmp_path}/p", "--control", f"ipc://{tmp_path}/c", "--no-hotplug"]
    if "--pub" in argv:
        base = base[2:]
    try:
        code = daemon_main.main(base + argv)
    except SystemExit as exit_:  # argparse: flag checks, with the usage line
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("stictiond: error: ") and message in err[-1], err
    assert not any("Traceback" in line for line in err)


def test_config_errors_name_file_line_and_key(tmp_path: Path) -> None:
    from stiction.daemon.config import ConfigError, load_options

    cfg = tmp_path / "c.toml"
    cfg.write_text('[daemon]\nrate = 100\n\n[[devices]]\nspec = "x"\nrotate = 45\n')
    with pytest.raises(ConfigError, match=r"c\.toml:6: devices\[0\]\.rotate: must be 0, 90"):
        load_options(cfg)
    cfg.write_text("[daemon]\nrat = 100\n")
    with pytest.raises(ConfigError, match=r"c\.toml:2: daemon\.rat: unknown key"):
        load_options(cfg)
    for line, message in (
        ("keepalive = -1", r"daemon\.keepalive: must be 0 \(every tick\) or more seconds"),
        ("spin_ms = 6", r"daemon\.spin_ms: must be from 0 to 5"),
        ("realtime = true", r"daemon\.realtime: must be a priority 1-99"),
        ("realtime = 100", r"daemon\.realtime: must be a priority 1-99"),
    ):
        cfg.write_text(f"[daemon]\n{line}\n")
        with pytest.raises(ConfigError, match=rf"c\.toml:2: {message}"):
            load_options(cfg)
    cfg.write_text("[daemon]\nkeepalive = 0\nspin_ms = 0\nrealtime = 20\n")
    opts = load_options(cfg)
    assert (opts.keepalive, opts.spin_ms, opts.realtime) == (0.0, 0.0, 20)
