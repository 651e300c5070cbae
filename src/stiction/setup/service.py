"""The systemd user unit for stictiond and where its config lives.

The unit ships as package data (stictiond.service beside this module) so it
can be read and verified as a file; installing it fills in the absolute path
of this installation's `stictiond`, because the user manager's PATH does not
include a virtualenv or ~/.local/bin. stictiond has no default config path
and refuses a --config file that does not exist, so the unit names
%E/stiction/stictiond.toml (%E is $XDG_CONFIG_HOME, default ~/.config) and
the installer writes a starter config there when there is none.
"""

from __future__ import annotations

import os
import shutil
import sys
from importlib import resources
from pathlib import Path

from stiction.errors import StictionError
from stiction.xdg import config_home

UNIT_NAME = "stictiond.service"

STARTER_CONFIG = """\
# stictiond configuration (TOML), read by the stictiond user service.
# With no [[devices]] entries stictiond opens every tablet and touchpad it can
# (see `stiction doctor`), or a synthetic pen when there is none.
# Reload after editing: systemctl --user reload stictiond
#
# [daemon]
# pub = "tcp://127.0.0.1:5556"   # where display clients subscribe (the default)
#
# [[devices]]
# spec = "/dev/input/event7"     # a node from `stiction doctor`, or "vvvv:pppp"
# grab = true                    # evdev only: the desktop cursor stops following the pen
# surface_size = [0.2235, 0.1397] # active area in metres, for a device reporting no size
"""


def unit_path() -> Path:
    return config_home() / "systemd" / "user" / UNIT_NAME


def config_path() -> Path:
    """The config file the unit passes to stictiond (%E/stiction/stictiond.toml)."""
    return config_home() / "stiction" / "stictiond.toml"


def shipped_unit() -> str:
    return resources.files("stiction.setup").joinpath(UNIT_NAME).read_text("utf-8")


def stictiond_executable() -> Path:
    """The stictiond script of this installation: beside the running Python first."""
    beside = Path(sys.executable).parent / "stictiond"
    if beside.is_file() and os.access(beside, os.X_OK):
        return beside.absolute()
    found = shutil.which("stictiond")
    if found is None:
        raise StictionError(
            "cannot find the stictiond executable of this installation; "
            "install stiction with pip (it creates stictiond) and run this again"
        )
    return Path(found).absolute()


def render_unit(executable: Path) -> str:
    """The shipped unit with ExecStart pointing at `executable`."""
    if any(c.isspace() for c in str(executable)) or "%" in str(executable):
        raise StictionError(
            f"{executable}: a path with spaces or '%' cannot go into a unit's ExecStart; "
            "install stiction in a directory without them"
        )
    out = []
    for line in shipped_unit().splitlines():
        if line.startswith("ExecStart=stictiond "):
            line = f"ExecStart={executable} " + line.split(" ", 1)[1]
        out.append(line)
    return "\n".join(out) + "\n"
