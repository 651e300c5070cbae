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
from stiction.errors import SizeUnknown, StictionError

COMMAND_MODULES = (
    "stiction.sim.cli",
    "stiction.drivers.cli",
    "stiction.drivers.hid.cli",
    "stiction.drivers.evdev.cli",
    "stiction.daemon.cli",
    "stiction.clients.cli",
    "stiction.demo",
    "stiction.setup.cli",
    "stiction.trace_cli",
    "stiction.experiment.cli",
)


def _results_snapshot(folder: Path) -> dict[Path, tuple[int, int]]:
    if not folder.is_dir():
        return {}
    return {p: (p.stat().st_mtime_ns, p.stat().st_size) for p in folder.iterdir() if p.is_file()}


def _bench_target(args: argparse.Namespace, rest: list[str]) -> Path:
    """The results folder of this run: --out, --save, else the per-user default."""
    from stiction.bench import _support

    if args.out is not None and args.save:
        raise StictionError("--out and --save exclude each other: --save means bench/results/")
    if args.save:
        if "--quick" in rest:
            raise StictionError(
                "--save: a --quick run is a smoke run and never replaces the committed figures"
            )
        return _support.committed_results()
    if args.out is not None:
        return Path(args.out)
    return _support.default_results()


def _run_bench(args: argparse.Namespace) -> int:
    from stiction import bench
    from stiction.bench import _support

    # --out/--save may come before or after the benchmark's name.
    own = argparse.ArgumentParser(prog="stiction bench", add_help=False, allow_abbrev=False)
    own.add_argument("--out", metavar="DIR")
    own.add_argument("--save", action="store_true")
    late, rest = own.parse_known_args(args.rest)
    args.out = late.out if late.out is not None else args.out
    args.save = args.save or late.save

    names = bench.names()
    wanted = names if args.name == "all" else [args.name]
    for name in wanted:
        if name not in names:
            raise StictionError(f"unknown benchmark {name!r}; known: {', '.join(names)}, all")
    missing = _support.missing_extra()
    if missing:
        raise StictionError(f"benchmarks need {', '.join(missing)}: {_support.EXTRA_HINT}")
    target = _bench_target(args, rest)
    _support.set_results_dir(target)
    status = 0
    try:
        for name in wanted:
            before = _results_snapshot(target)
            module = importlib.import_module(f"stiction.bench.{name}")
            status |= int(module.main(list(rest)))
            after = _results_snapshot(target)
            written = sorted(p.name for p, stamp in after.items() if before.get(p) != stamp)
            if written:
                print(
                    f"stiction bench {name}: wrote {', '.join(written)} in {target}",
                    file=sys.stderr,
                )
    finally:
        _support.set_results_dir(None)
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
        help="run a benchmark (accuracy, hid, evdev, daemon, ... or all)",
        description="Run a benchmark: it prints a table and writes its figures (.txt, .json, "
        ".png) to a results folder, and says which files it wrote. The folder is --out DIR; "
        "else $STICTION_BENCH_RESULTS; else $XDG_CACHE_HOME/stiction/bench (~/.cache/...). "
        "--save writes the committed figures in the source checkout's bench/results/ instead. "
        "Every benchmark also takes --json (print its results as JSON) and its own flags: "
        "stiction bench NAME --help. Needs the bench extra: pip install 'stiction[bench]'.",
    )
    bench.add_argument("--out", metavar="DIR", help="write the results into DIR")
    bench.add_argument(
        "--save",
        action="store_true",
        help="write into the checkout's bench/results/ (the figures the docs quote)",
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
        how = getattr(args, "size_how", None)
        if isinstance(exc, SizeUnknown) and how:  # name this command's own flag
            exc = exc.told(how)
        print(f"stiction: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0
    except KeyboardInterrupt:
        return 130
