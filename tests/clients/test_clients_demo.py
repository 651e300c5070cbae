"""`stiction demo`: the real daemon on the synthetic pen, the renderer, and cleanup."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

pytest_plugins = ["clients_fixtures"]

pytestmark = pytest.mark.slow

STICTION = Path(sys.executable).with_name("stiction")
URL = re.compile(r"open (http://127\.0\.0\.1:\d+/) in a browser")
PID = re.compile(r"\(pid (\d+)\)")


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_demo_headless_run_ends_cleanly() -> None:
    res = subprocess.run(
        [str(STICTION), "demo", "--seconds", "2", "--port", "0"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    assert URL.search(res.stdout), res.stdout
    received = re.search(r"the renderer received (\d+) frames and (\d+) scene", res.stdout)
    assert received and int(received[1]) > 50 and int(received[2]) >= 1, res.stdout
    pid = PID.search(res.stdout)
    assert pid and not alive(int(pid[1])), "the daemon outlived the demo"


def test_demo_bad_scene_is_one_line(tmp_path: Path) -> None:
    res = subprocess.run(
        [str(STICTION), "demo", "--seconds", "1", "--port", "0", "--scene", str(tmp_path / "x")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 2
    assert res.stderr.startswith("stiction: error: scene file") and "Traceback" not in res.stderr


def test_demo_with_a_directory_as_its_scene_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It said 'scene file DIR not found' of a folder that is there."""
    from stiction.cli import main

    assert main(["demo", "--seconds", "1", "--port", "0", "--scene", str(tmp_path)]) == 2
    assert "not a regular file" in capsys.readouterr().err


@pytest.mark.browser
def test_demo_page_shows_the_demo_scene_and_stops_on_ctrl_c(browser: Any) -> None:
    proc = subprocess.Popen(
        [str(STICTION), "demo", "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    page = browser.new_page(viewport={"width": 1000, "height": 640})
    try:
        assert proc.stdout is not None
        lines = [proc.stdout.readline(), proc.stdout.readline()]
        url = URL.search(lines[1])
        pid = PID.search(lines[0])
        assert url and pid, lines
        page.goto(url[1])
        page.wait_for_function(
            "window.stiction.scene && window.stiction.scene.name === 'demo'"
            " && window.stiction.drawnTick > 0 && window.stiction.status === 'live'",
            timeout=30_000,
        )
        size = page.evaluate("[view.width, view.height]")
        assert size == [1920, 1080]  # the demo scene's display, 1:1
        assert "synthetic-demo" in page.inner_text("#status")
        proc.send_signal(signal.SIGINT)  # Ctrl-C
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        assert "stopped; the renderer received" in out
        # The demo waited for its daemon, so the pid is already gone.
        assert not alive(int(pid[1])), "the daemon outlived the demo"
    finally:
        page.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_demo_port_in_use_is_one_line_and_leaves_no_daemon() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = subprocess.run(
            [str(STICTION), "demo", "--seconds", "5", "--port", str(port)],
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert res.returncode == 2
    assert res.stderr.startswith(f"stiction: error: port {port}") and "Traceback" not in res.stderr
    pid = PID.search(res.stdout)
    assert pid and not alive(int(pid[1]))
