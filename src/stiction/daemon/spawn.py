"""How to start this installation's stictiond as a child process.

Shared by the tools that run a daemon of their own (`stiction demo`, the
steered experiment runs); it lives with the daemon rather than in a
command-line module so that library code never imports a command.
"""

from __future__ import annotations

import sys
from pathlib import Path


def daemon_command() -> list[str]:
    """The stictiond of this installation (beside this Python), not one on PATH."""
    exe = Path(sys.executable).with_name("stictiond")
    if exe.exists():
        return [str(exe)]
    return [
        sys.executable,
        "-c",
        "import sys; from stiction.daemon.main import main; sys.exit(main())",
    ]
