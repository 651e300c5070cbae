"""Reading a file a user named: a regular file of bounded size, or one clear error.

Scenes, the daemon's config, recordings and traces are read from paths that
users (and, through set_scene, any local process) give. Such a path may be a
FIFO with no writer, /dev/zero or a directory; reading it must be refused
before it can block or exhaust anything. Opened non-blocking and checked
with fstat; the caller chooses the limit and the error type its users see.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from stiction.errors import StictionError


def read_regular_text(path: str | Path, limit: int, error: type[StictionError], what: str) -> str:
    """The text of `path`; else `error`: not a regular file, over `limit` bytes, unreadable."""
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY)
    except OSError as exc:
        raise error(f"{p}: cannot read {what}: {exc.strerror or exc}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise error(f"{p}: not a regular file; a {what} must be a file")
        if st.st_size > limit:
            raise error(f"{p}: {st.st_size} bytes; a {what} is at most {limit}")
        chunks = []
        size = 0
        while True:
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                break
            size += len(chunk)
            if size > limit:
                raise error(f"{p}: grew past {limit} bytes while being read")
            chunks.append(chunk)
    except OSError as exc:
        raise error(f"{p}: cannot read {what}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    return b"".join(chunks).decode("utf-8", errors="replace")
