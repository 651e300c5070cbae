"""Mocked evdev nodes for the tests: umockdev-run and the GI unplug controller.

The three files of a node are built by stiction.bench._umockdev_evdev (shared
with the fault benchmark's device storm); this module runs programs against
them.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from stiction.bench._umockdev_evdev import MockFiles, ioctl_text, umockdev_text, write
from stiction.drivers.evdev.recording import Recording

__all__ = ["MockFiles", "ioctl_text", "umockdev_text", "write"]

REPO = Path(__file__).resolve().parents[2]
VENV_PY = REPO / ".venv" / "bin" / "python"


def umockdev_available() -> bool:
    return shutil.which("umockdev-run") is not None


def gi_available() -> bool:
    """Whether `run_controller` can run: system python3 with gi and the UMockdev typelib."""
    if not Path("/usr/bin/python3").exists() or shutil.which("umockdev-wrapper") is None:
        return False
    probe = "import gi; gi.require_version('UMockdev', '1.0'); from gi.repository import UMockdev"
    r = subprocess.run(["/usr/bin/python3", "-c", probe], capture_output=True, check=False)
    return r.returncode == 0


def write_replug_pair(rec: Recording, out: Path, frames: int, udev: dict[str, str]) -> None:
    """Cut `rec` (in place) to its first `frames` frames and write it as event5, the
    node `run_controller` unplugs, and as event6, the node it plugs back in."""
    syn = [i for i, ev in enumerate(rec.events) if ev[2:4] == (0, 0)]
    rec.events = rec.events[: syn[frames - 1] + 1]
    write(rec, out, num=5, udev=udev)
    write(rec, out, num=6, udev=udev)


def run_under_umockdev(
    files: list[MockFiles], argv: list[str], timeout: float = 60.0
) -> subprocess.CompletedProcess[str]:
    """Run `argv` (a program using the production driver) with the nodes mocked."""
    cmd = ["umockdev-run"]
    for f in files:
        cmd += ["--device", str(f.umockdev)]
    for f in files:
        cmd += ["--ioctl", f"{f.node}={f.ioctl}"]
    for f in files:
        cmd += ["--evemu-events", f"{f.node}={f.events}"]
    cmd += ["--", *argv]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO
    )
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        # SIGTERM first: umockdev-run then removes its temporary root (SIGKILL leaves it)
        proc.terminate()
        try:
            out, err = proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
        raise AssertionError(
            f"timed out after {timeout} s: {argv}\nstdout: {out[-2000:]}\nstderr: {err[-2000:]}"
        ) from None
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def run_controller(
    directory: Path, reader: str, *args: str, timeout: float = 60.0
) -> dict[str, Any]:
    """Run `reader` against the mocked nodes in `directory` under the GI controller
    (evdev_unplug_controller.py, system python3), and return the controller's report.

    The controller is what can unplug a node with a real ENODEV, count EVIOCGRAB
    calls or answer SYN_DROPPED re-queries (umockdev-evdev.md, section 6).
    """
    controller = Path(__file__).with_name("evdev_unplug_controller.py")
    argv = [str(controller), str(directory), stiction_cmd()[0], reader, *args]
    proc = subprocess.run(
        ["umockdev-wrapper", "/usr/bin/python3", *argv],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    report: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return report


def stiction_cmd(*args: str) -> list[str]:
    py = str(VENV_PY) if VENV_PY.exists() else sys.executable
    return [py, "-m", "stiction", *args]
