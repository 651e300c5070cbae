"""Writing one installed file, or saying exactly what would be written.

Shared by `stiction udev install` and `stiction service install` so both
behave the same: --dry-run changes nothing, an identical file is left alone,
and a file that cannot be written is a one-line StictionError naming it.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

from stiction.errors import StictionError
from stiction.userfiles import read_regular_text


@dataclass(frozen=True, slots=True)
class Outcome:
    path: Path
    action: str  # "written", "unchanged" or "would write"


def install_text(
    path: Path, text: str, dry_run: bool, mode: int = 0o644, force: bool = False, show: str = ""
) -> Outcome:
    """Write `text` to `path` atomically (temp file + rename) unless it is already there.

    A file that exists with other content (the user's own edits, or another
    version's) is replaced only with `force`; `show` is the command that
    prints what would be written, for the message.
    """
    current = _current(path)
    if current == text:
        return Outcome(path, "unchanged")
    if dry_run:
        return Outcome(path, "would write")
    if current is not None and not force:
        compare = f" (compare: `{show} | diff {shlex.quote(str(path))} -`)" if show else ""
        raise StictionError(
            f"{path} exists with other content{compare}; pass --force to replace it"
        )
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text(text, encoding="utf-8")
        tmp.chmod(mode)
        tmp.replace(path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise StictionError(f"cannot write {path}: {exc.strerror or exc}") from None
    return Outcome(path, "written")


MAX_INSTALLED_BYTES = 1 << 20
"""A udev rules file or a systemd unit is a few kilobytes; a larger file there is not ours."""


def _current(path: Path) -> str | None:
    """What `path` holds now, None if nothing is there.

    Read as a regular file only (a FIFO given as --path blocked the install)
    and decoded leniently (a binary file made the install a UnicodeDecodeError
    traceback): either way it differs from our text and --force is asked for.
    """
    try:
        path.stat()  # follows a link: a dangling one is nothing there, as before
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        raise StictionError(f"cannot read {path}: {exc.strerror or exc}") from None
    return read_regular_text(path, MAX_INSTALLED_BYTES, StictionError, "file to replace")


def is_root() -> bool:
    return os.geteuid() == 0


def stiction_command() -> str:
    """How to run this installation's `stiction` from sudo, whose PATH rarely has a venv."""
    beside = Path(sys.executable).parent / "stiction"
    if beside.is_file() and os.access(beside, os.X_OK):
        return shlex.quote(str(beside.absolute()))
    return "stiction"


def install_rules_command() -> str:
    return f"sudo {stiction_command()} udev install"
