"""What every benchmark shares: where results go, where the shared recordings are, progress.

Results never land in the committed figures by accident. The folder is chosen
once per run by `stiction bench` (``--out DIR``, ``--save`` for the checkout's
bench/results/, else ``$STICTION_BENCH_RESULTS``, else a per-user cache
folder) and handed to the benchmarks through `set_results_dir`; a benchmark
only ever asks `results_dir()`.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from types import TracebackType
from typing import Any

from stiction.errors import StictionError
from stiction.xdg import cache_home

ENV_RESULTS = "STICTION_BENCH_RESULTS"
# The modules `pip install 'stiction[bench]'` brings (the daemon needs none of them).
EXTRA_MODULES = ("matplotlib", "tqdm", "hidtools")
EXTRA_HINT = "pip install 'stiction[bench]'"

_chosen: Path | None = None


def source_checkout() -> Path | None:
    """The source checkout this package runs from, or None for an installed package.

    A checkout is recognised by its layout (src/stiction beside pyproject.toml
    and bench/results/), not by the current directory: figures saved with
    ``--save`` must be measured with the code of the checkout they land in.
    """
    root = Path(__file__).resolve().parents[3]
    if (root / "pyproject.toml").is_file() and (root / "bench" / "results").is_dir():
        return root
    return None


def committed_results() -> Path:
    """bench/results/ of the source checkout: the figures the docs quote."""
    root = source_checkout()
    if root is None:
        raise StictionError(
            f"--save writes the committed figures into a source checkout's bench/results/, "
            f"but this stiction is installed ({Path(__file__).resolve().parents[1]}); "
            "run it from a checkout (PYTHONPATH=src or pip install -e .) or use --out DIR"
        )
    return root / "bench" / "results"


def default_results() -> Path:
    """The per-user results folder: $STICTION_BENCH_RESULTS, else $XDG_CACHE_HOME/stiction/bench."""
    env = os.environ.get(ENV_RESULTS)
    if env:
        return Path(env)
    return cache_home() / "stiction" / "bench"


def set_results_dir(path: Path | None) -> None:
    """Chosen by the command line for the whole run (None: back to the default)."""
    global _chosen
    _chosen = path


def results_dir() -> Path:
    """Where this run writes its results (created on first use)."""
    path = _chosen or default_results()
    path.mkdir(parents=True, exist_ok=True)
    return path


def shared_data(kind: str, given: str | None) -> Path:
    """A folder of recordings: --data when given, else the shared/ data beside the checkout."""
    if given:
        path = Path(given)
    else:
        root = source_checkout()
        base = root.parent if root is not None else Path.cwd()
        path = base / "shared" / "data" / kind
    if not path.is_dir():
        raise StictionError(
            f"--data: recordings folder {path} not found; pass --data DIR "
            f"(the shared/data/{kind} folder of the project's shared data)"
        )
    return path


def missing_extra() -> list[str]:
    """Modules of the bench extra that are not installed."""
    import importlib.util

    missing = []
    for name in EXTRA_MODULES:
        try:
            found = importlib.util.find_spec(name) is not None
        except (ImportError, ValueError):  # a broken or blocked install counts as missing
            found = False
        if not found:
            missing.append(name)
    return missing


class NoBar:
    """Stands in for a tqdm bar when stderr is not a terminal."""

    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, s: str) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> NoBar:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        pass


def progress(total: float, desc: str, unit: str = "it") -> Any:
    """A tqdm bar on stderr when stderr is a terminal; a silent stand-in otherwise.

    Benchmark output (tables, --json) goes to stdout and stays clean; logs and
    pipes get no carriage-return noise.
    """
    if not sys.stderr.isatty():
        return NoBar()
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, leave=False)
