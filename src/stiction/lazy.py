"""A package's public names imported on first use (PEP 562).

`stiction --help` imports every command module and so every package they
live in; a package whose __init__ imported numpy or pyzmq up front would make
the help (and every argument error) pay for it. Such a package lists where
each name lives and installs the pair this returns as its module-level
``__getattr__`` and ``__dir__``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, MutableMapping, Sequence


def exports(
    package: str,
    sources: Mapping[str, str],
    namespace: MutableMapping[str, object],
    names: Sequence[str],
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for `package`: `sources` maps each public
    name to the module that defines it; `namespace` is the package's globals()
    (a name, once imported, is stored there and never looked up again)."""

    def getattr_(name: str) -> object:
        source = sources.get(name)
        if source is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(source), name)
        namespace[name] = value
        return value

    def dir_() -> list[str]:
        return sorted({*namespace, *names})

    return getattr_, dir_
