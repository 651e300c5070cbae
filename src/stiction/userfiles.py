"""Reading a file a user named: a regular file of bounded size, or one clear error.

Scenes, the daemon's config, recordings and traces are read from paths that
users (and, through set_scene, any local process) give. Such a path may be a
FIFO with no writer, /dev/zero or a directory; reading it must be refused
before it can block or exhaust anything. Opened non-blocking and checked
with fstat; the caller chooses the limit and the error type its users see.
The path itself is untrusted too: one with a NUL byte is refused in words
(os.open would raise ValueError, which no caller expects), and a path
thousands of characters long is shortened where an error message repeats it.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import BinaryIO, TextIO

from stiction.errors import StictionError

MAX_SHOWN = 160
"""Characters of a user's string that an error message repeats: enough to
recognise a path or a name, never a megabyte echoed into a reply or a log."""


def shown(text: object, limit: int = MAX_SHOWN) -> str:
    """`text` as an error message quotes it: at most `limit` characters, the cut said."""
    s = str(text)
    if len(s) <= limit:
        return s
    return f"{s[:limit]}... ({len(s)} characters)"


def _open_checked(p: Path, limit: int | None, error: type[StictionError], what: str) -> int:
    """A descriptor of the regular file `p` of at most `limit` bytes (None: any size),
    opened without blocking: the file is checked through the descriptor it is read
    by, so nothing can be swapped in between the check and the read."""
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY)
    except OSError as exc:
        raise error(f"{shown(p)}: cannot read {what}: {exc.strerror or exc}") from None
    except ValueError:  # a NUL byte: no file can have this name
        raise error(f"{shown(repr(str(p)))}: not a file name (it holds a NUL byte)") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise error(f"{shown(p)}: not a regular file; a {what} must be a file")
        if limit is not None and st.st_size > limit:
            raise error(f"{shown(p)}: {st.st_size} bytes; a {what} is at most {limit}")
    except OSError as exc:
        os.close(fd)
        raise error(f"{shown(p)}: cannot read {what}: {exc.strerror or exc}") from None
    except BaseException:
        os.close(fd)
        raise
    return fd


def open_regular(path: str | Path, limit: int, error: type[StictionError], what: str) -> BinaryIO:
    """`path` opened for binary reading, refused like `read_regular_text` refuses it.

    For readers that take a file object (numpy's .npz loader, a spool): the
    checks happen before a byte is read, and the caller reads at most what
    fstat said, since a regular file cannot block.
    """
    fd = _open_checked(Path(path), limit, error, what)
    return os.fdopen(fd, "rb")


def open_regular_text(path: str | Path, error: type[StictionError], what: str) -> TextIO:
    """`path` opened to be streamed as UTF-8 text (a CSV of any length), refused
    like `read_regular_text` refuses it but with no size bound: the reader holds
    one row at a time, and a regular file cannot block."""
    fd = _open_checked(Path(path), None, error, what)
    return open(fd, newline="", encoding="utf-8")


def read_regular_text(path: str | Path, limit: int, error: type[StictionError], what: str) -> str:
    """The text of `path`; else `error`: not a regular file, over `limit` bytes, unreadable."""
    p = Path(path)
    fd = _open_checked(p, limit, error, what)
    try:
        chunks = []
        size = 0
        while True:
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                break
            size += len(chunk)
            if size > limit:
                raise error(f"{shown(p)}: grew past {limit} bytes while being read")
            chunks.append(chunk)
    except OSError as exc:
        raise error(f"{shown(p)}: cannot read {what}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    return b"".join(chunks).decode("utf-8", errors="replace")
