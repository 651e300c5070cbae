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
    try:
        current = path.read_text(encoding="utf-8")
    except (FileNotFoundError, NotADirectoryError):
        current = None
    except OSError as exc:
        raise StictionError(f"cannot read {path}: {exc.strerror or exc}") from None
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
