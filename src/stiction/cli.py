"""The `stiction` command: one entry point, sub-commands registered by the packages.

Each package that offers commands has a ``cli`` module with
``register(subparsers)``; it adds its parsers and sets ``func`` (taking the
parsed namespace, returning an exit status). Command modules import their
heavy dependencies inside the handlers so that ``stiction --help`` stays fast.

User mistakes surface as `StictionError` and are printed as one line, never as
a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from stiction import __version__
from stiction.errors import StictionError

COMMAND_MODULES = (
    "stiction.sim.cli",
    "stiction.drivers.cli",
    "stiction.drivers.hid.cli",
    "stiction.drivers.evdev.cli",
    "stiction.daemon.cli",
    "stiction.clients.cli",
    "stiction.demo",
    "stiction.setup.cli",
)


def bench_dir() -> Path:
    """bench/ of the source checkout this package runs from."""
    return Path(__file__).resolve().parents[2] / "bench"


def _bench_names() -> list[str]:
    d = bench_dir()
    if not d.is_dir():
        return []
    return sorted(p.stem for p in d.glob("*.py") if not p.stem.startswith("_"))


def _run_bench(args: argparse.Namespace) -> int:
    import importlib.util

    names = _bench_names()
    if not names:
        raise StictionError(
            f"no benchmarks found in {bench_dir()}: benchmarks run from a source checkout"
        )
    wanted = names if args.name == "all" else [args.name]
    status = 0
    for name in wanted:
        if name not in names:
            raise StictionError(f"unknown benchmark {name!r}; known: {', '.join(names)}, all")
        spec = importlib.util.spec_from_file_location(
            f"stiction_bench_{name}", bench_dir() / f"{name}.py"
        )
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        # Registered before running, as an import would, so that dataclasses
        # and pickling inside the benchmark can find their own module.
        sys.modules[spec.name] = module
        spec.loader.exec_module(module)
        status |= int(module.main(list(args.rest)))
    return status


def _verbose_after_subcommands(sub: argparse._SubParsersAction[Any]) -> None:
    """Accept `-v` after any subcommand too (`stiction doctor -v`), as users type it.

    The default is SUPPRESS so that a subcommand without `-v` keeps the count given before it.
    """
    seen: set[int] = set()
    for parser in sub.choices.values():
        if id(parser) in seen:  # aliases share one parser
            continue
        seen.add(id(parser))
        if any("-v" in a.option_strings for a in parser._actions):
            continue
        parser.add_argument(
            "-v", "--verbose", action="count", default=argparse.SUPPRESS, help="more log output"
        )
        nested = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        for action in nested:
            _verbose_after_subcommands(action)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stiction",
        description="Pseudo-haptic stick-slip friction for pen tablets and touchpads.",
    )
    parser.add_argument("--version", action="version", version=f"stiction {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    _verbose_after_subcommands(sub)
    bench = sub.add_parser(
        "bench",
        help="run a benchmark from bench/ (accuracy, hid, evdev, daemon, ... or all)",
        description="Run a benchmark; it prints a table and writes its figures to bench/results/ "
        "(or to $STICTION_BENCH_RESULTS when set).",
    )
    bench.add_argument("name", help="benchmark name, or 'all'")
    bench.add_argument("rest", nargs=argparse.REMAINDER, help="arguments for the benchmark")
    bench.set_defaults(func=_run_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    import logging  # not before: `stiction --help` and argument errors do not need it

    logging.basicConfig(
        level=logging.WARNING - 10 * min(args.verbose, 2),
        format="%(levelname)s %(name)s: %(message)s",
    )
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except StictionError as exc:
        print(f"stiction: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0
    except KeyboardInterrupt:
        return 130
