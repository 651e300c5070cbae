"""numba's cache goes to the user's cache folder when the installed package is read-only."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.sim import numba_cache

pytest.importorskip("numba")
SRC = Path(__file__).resolve().parents[2] / "src"


def test_cache_folder_choice(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert numba_cache.base_dir(tmp_path) == tmp_path / "__pycache__" / "numba"
    assert numba_cache.user_cache_dir() == tmp_path / "xdg" / "stiction" / "numba"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert numba_cache.base_dir(tmp_path) == tmp_path / "mine"


def test_the_cache_key_follows_every_source(tmp_path: Path) -> None:
    a, b = tmp_path / "a.py", tmp_path / "b.py"
    a.write_text("x = 1\n")
    b.write_text("y = 1\n")
    key = numba_cache.source_key([a, b])
    b.write_text("y = 2\n")
    assert numba_cache.source_key([a, b]) != key


def test_read_only_package_compiles_into_the_user_cache(tmp_path: Path) -> None:
    """A copy of the package on a read-only bind mount (needs root and mount namespaces)."""
    if shutil.which("unshare") is None or os.geteuid() != 0:
        pytest.skip("needs root and unshare for a read-only bind mount")
    pkg = tmp_path / "site"
    shutil.copytree(
        SRC / "stiction", pkg / "stiction", ignore=shutil.ignore_patterns("__pycache__")
    )
    xdg = tmp_path / "xdg"
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(XDG_CACHE_HOME=str(xdg), PYTHONPATH=str(pkg), PYTHONDONTWRITEBYTECODE="1")
    code = "from stiction.sim.batch import warm_up; assert warm_up()"
    script = f'mount --bind -o ro "{pkg}" "{pkg}" && exec "{sys.executable}" -c "{code}"'
    probe = subprocess.run(["unshare", "-m", "true"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip("no mount namespace here")
    run = subprocess.run(
        ["unshare", "-m", "sh", "-c", script], env=env, capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr[-2000:]
    cached = list((xdg / "stiction" / "numba").rglob("*.nbi"))
    assert cached, "numba wrote no index into the user cache"
    assert not list(pkg.rglob("*.nbi")), "numba wrote beside the read-only package"


def test_is_cached_tells_a_load_from_a_first_compilation(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Pipeline.warm_up waits for a load but not for a compilation: is_cached decides."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    mod = tmp_path / "cached_fn.py"
    mod.write_text("def double(x):\n    return 2 * x\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import cached_fn  # type: ignore[import-not-found]

    first = numba_cache.njit_cached(cached_fn.double)
    assert numba_cache.is_cached(first) is False
    assert first(21) == 42  # compiles, and writes the cache
    again = numba_cache.njit_cached(cached_fn.double)
    assert numba_cache.is_cached(again) is True
    assert numba_cache.is_cached(cached_fn.double) is None  # not a dispatcher
