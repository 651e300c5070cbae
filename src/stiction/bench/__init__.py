"""Benchmarks, shipped with the package so that `stiction bench NAME` works after `pip install .`.

Each module here other than those starting with ``_`` is one benchmark with
``main(argv) -> int``: it prints a table, compares against the naive
alternative in the same run, and writes its figures to
`stiction.bench._support.results_dir()`. They need the ``bench`` extra
(matplotlib, tqdm, hid-tools); the daemon needs none of it.
"""

from __future__ import annotations

import pkgutil


def names() -> list[str]:
    """The benchmarks this package ships, sorted."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))
