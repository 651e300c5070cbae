"""Where numba keeps the batch step's compiled machine code, and when it is stale.

Two problems with numba's own cache (``cache=True``):

- It writes beside the source file it compiles, in the installed package. A
  package installed by root, or from a read-only image, is not writable by
  the user running the daemon: every start would compile for seconds again.
  Then the cache goes to ``$XDG_CACHE_HOME/stiction/numba`` (``~/.cache/...``
  without XDG_CACHE_HOME) instead; NUMBA_CACHE_DIR, when the user sets it,
  wins over both.
- It checks only the timestamp of the file holding the compiled function,
  not of the functions it calls: the scene pipeline's tick (scene/tick.py)
  and the batch loops (sim/step.py) call step.py's and kernels.py's
  functions, and a change there alone would load stale machine code. So
  each compiled function caches under a folder named by a hash of its own
  file and of those two.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from stiction.xdg import cache_home

PACKAGE_DIR = Path(__file__).resolve().parent
DEPENDENCIES = (
    PACKAGE_DIR / "step.py",
    PACKAGE_DIR / "kernels.py",
    PACKAGE_DIR / "batch_kernel.py",
)
"""What every compiled loop calls, and how it is compiled: part of every cache key."""


def user_cache_dir() -> Path:
    return cache_home() / "stiction" / "numba"


def writable(folder: Path) -> bool:
    """Can this process create (or write in) the __pycache__ folder under `folder`?"""
    cache = folder / "__pycache__"
    target = cache if cache.is_dir() else folder
    return os.access(target, os.W_OK | os.X_OK)


def base_dir(package_dir: Path = PACKAGE_DIR) -> Path:
    """NUMBA_CACHE_DIR if set, else beside the package when writable, else the user's folder."""
    chosen = os.environ.get("NUMBA_CACHE_DIR")
    if chosen:
        return Path(chosen)
    if writable(package_dir):
        return package_dir / "__pycache__" / "numba"
    return user_cache_dir()


def source_key(sources: Iterable[Path]) -> str:
    digest = hashlib.sha256()
    for path in sorted(set(sources)):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def njit_cached(fn: Callable[..., Any], **options: Any) -> Any:
    """numba.njit(fn, cache=True) with its cache in base_dir()/<hash of its sources>."""
    import importlib
    import inspect

    import numba  # type: ignore[import-untyped]

    config: Any = importlib.import_module("numba.core.config")

    folder = base_dir() / source_key([Path(inspect.getfile(fn)), *DEPENDENCIES])
    folder.mkdir(parents=True, exist_ok=True)
    saved = config.CACHE_DIR
    config.CACHE_DIR = str(folder)  # read when the dispatcher sets up its cache, just below
    try:
        return numba.njit(cache=True, **options)(fn)
    finally:
        config.CACHE_DIR = saved


def is_cached(dispatcher: Any) -> bool | None:
    """Whether numba's cache holds an index for this compiled function (None: cannot tell).

    Lets a caller tell a load (a fraction of a second) from a first
    compilation (seconds to a minute) before it starts either. Reads numba's
    own record of where the index lives (private, hence the None when a
    numba version has it elsewhere).
    """
    cache = getattr(dispatcher, "_cache", None)
    index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
    if not isinstance(index, str):
        return None
    return os.path.exists(index)
