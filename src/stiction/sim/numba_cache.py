"""Where numba keeps its compiled machine code.

numba caches beside the source file it compiles (a __pycache__ folder in
the installed package). A package installed by root, or from a read-only
image, is not writable by the user running the daemon: then every start
would compile for seconds again. This module points numba at the user's
cache folder instead, ``$XDG_CACHE_HOME/stiction/numba`` (``~/.cache/...``
without XDG_CACHE_HOME), unless the user chose a folder with
NUMBA_CACHE_DIR. It must run before numba is imported, or at least before
the first function is compiled with cache=True.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent


def user_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "stiction" / "numba"


def writable(folder: Path) -> bool:
    """Can this process create the __pycache__ folder numba would use (or write in it)?"""
    cache = folder / "__pycache__"
    target = cache if cache.is_dir() else folder
    return os.access(target, os.W_OK | os.X_OK)


def configure_cache_dir(package_dir: Path = PACKAGE_DIR) -> Path | None:
    """Set numba's cache folder to the user's when the package folder is read-only.

    Returns the folder chosen, or None when numba's default (beside the
    package) is used or the user set NUMBA_CACHE_DIR.
    """
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    if writable(package_dir):
        return None
    folder = user_cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba already imported: its config was read at import
        config.CACHE_DIR = str(folder)  # type: ignore[attr-defined]
    return folder
