"""The `stictiond` entry point: flags, config, signals, run.

SIGTERM and SIGINT stop the loop at the next tick boundary and close every
device and socket; SIGHUP re-reads the config file and the scene, keeping the
current ones if either is bad. User mistakes print one line, no traceback.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from stiction import __version__
from stiction.argtypes import (
    endpoint,
    hwm,
    int_range,
    non_negative_float,
    positive_float,
    positive_int,
    seconds,
    seconds_or_zero,
)
from stiction.errors import StictionError

if TYPE_CHECKING:
    from stiction.daemon.options import Options

log = logging.getLogger("stiction.daemon")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="stictiond",
        description="Read pen tablets and touchpads, simulate stick-slip friction at a fixed "
        "rate, publish pointer and string over ZeroMQ (docs/daemon.md, docs/protocol.md).",
    )
    p.add_argument("--version", action="version", version=f"stictiond {__version__}")
    p.add_argument("--config", type=Path, metavar="FILE", help="TOML config file")
    p.add_argument(
        "--device",
        action="append",
        default=[],
        metavar="SPEC",
        help="device: /dev/hidrawN, /dev/input/eventN, VID:PID, a name, replay:PATH, "
        "synthetic:NAME; hidraw:VID:PID or evdev:VID:PID picks the backend (repeatable; "
        "default: every tablet found, each through the backend docs/devices.md says, "
        "else synthetic:demo)",
    )
    p.add_argument("--scene", type=Path, metavar="FILE", help="scene TOML (default: built-in)")
    p.add_argument("--pub", type=endpoint, metavar="ENDPOINT", help="publisher endpoint")
    p.add_argument("--control", type=endpoint, metavar="ENDPOINT", help="control endpoint")
    p.add_argument(
        "--clock",
        choices=("real", "virtual"),
        help="real: live, at the tick rate; virtual: replay as fast as possible and exit",
    )
    p.add_argument("--rate", type=positive_float, metavar="HZ", help="tick rate (default 100)")
    p.add_argument("--seconds", type=seconds, metavar="S", help="stop after S seconds of ticks")
    p.add_argument(
        "--wait-subscribers",
        type=positive_int,
        metavar="N",
        help="--clock virtual: hold the first tick until N subscribers have subscribed "
        "(a replay that runs before its readers subscribe loses its first frames)",
    )
    p.add_argument(
        "--wait-timeout",
        type=seconds,
        metavar="S",
        help="give up waiting for subscribers after S seconds and start (default 30)",
    )
    p.add_argument("--integrator", help="simulator integrator (see stiction simulate)")
    p.add_argument("--hwm", type=hwm, help="PUB high-water mark per subscriber (messages)")
    p.add_argument(
        "--keepalive",
        type=seconds_or_zero,
        metavar="S",
        help="seconds between frames of a device with nothing new (default 1; 0: every tick)",
    )
    p.add_argument(
        "--realtime",
        type=int_range(0, 99),
        metavar="PRIO",
        help="run the loop under SCHED_FIFO at this priority, 1-99, 0: off (needs CAP_SYS_NICE "
        "or RLIMIT_RTPRIO; refused: logged, ordinary scheduling)",
    )
    p.add_argument(
        "--spin-ms",
        type=non_negative_float,
        metavar="MS",
        help="wake this early and poll the clock to each deadline (default 0.3; 0: just sleep)",
    )
    p.add_argument("--curve-secret-key", type=Path, metavar="FILE", help="daemon .key_secret")
    p.add_argument("--curve-authorized", type=Path, metavar="DIR", help="authorised client keys")
    p.add_argument(
        "--curve-required", action="store_true", help="use CURVE on loopback endpoints too"
    )
    p.add_argument("--no-hotplug", action="store_true", help="do not watch for devices")
    p.add_argument("--log-format", choices=("text", "json"), default="text")
    p.add_argument("-v", "--verbose", action="count", default=0)
    return p


def options_from_args(args: argparse.Namespace) -> Options:
    """Flags over the config file over the defaults, checked by the one validate()."""
    from stiction.daemon.config import load_options
    from stiction.daemon.devices import DeviceConfig
    from stiction.daemon.options import Options, validate
    from stiction.daemon.security import CurveConfig

    opts = load_options(args.config) if args.config else Options()
    if args.device:
        from stiction.daemon.devices import parse_spec, spec_problem

        for text in args.device:
            problem = spec_problem(parse_spec(text))
            if problem is not None:
                raise StictionError(f"--device {text!r}: {problem}")
        known = {d.spec: d for d in opts.devices}
        opts.devices = [known.get(spec, DeviceConfig(spec)) for spec in args.device]
    if args.scene:
        opts.scene = args.scene
        opts.scene_from_flag = True
    for name in (
        "pub", "control", "clock", "rate", "seconds", "integrator", "hwm", "keepalive", "spin_ms",
        "realtime", "wait_subscribers", "wait_timeout",
    ):  # fmt: skip
        value = getattr(args, name)
        if value is not None:
            setattr(opts, name, value)
    if args.curve_secret_key or args.curve_authorized or args.curve_required:
        opts.curve = CurveConfig(
            secret_key=args.curve_secret_key or opts.curve.secret_key,
            authorized_keys=args.curve_authorized or opts.curve.authorized_keys,
            required=args.curve_required or opts.curve.required,
        )
    if args.no_hotplug:
        opts.hotplug = False
    return validate(opts)


def _fixed_mmap_threshold() -> None:
    """Keep glibc from raising its mmap threshold after a large free.

    By default glibc raises the threshold to the size of any large block
    freed, after which buffers of that size (a 1 MiB control request, say)
    come from the heap and are never returned: a daemon that once saw a few
    big requests keeps their memory for good. A fixed 128 KiB threshold keeps
    large buffers mmapped and returned (`stiction bench faults` measures it).
    Elsewhere than glibc this does nothing.
    """
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt(-3, 128 * 1024)  # M_MMAP_THRESHOLD
    except (OSError, AttributeError):
        pass


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    _fixed_mmap_threshold()
    from stiction.daemon import logs

    logs.setup(args.log_format, args.verbose)
    # The handlers go in before the daemon opens: it logs "started" as it opens,
    # and a Ctrl-C or SIGTERM that follows at once must stop it cleanly, not
    # raise KeyboardInterrupt through an unfinished start.
    daemon = None
    asked: set[str] = set()

    def stop(*_: object) -> None:
        asked.add("stop")
        if daemon is not None:
            daemon.request_stop()

    def reload(*_: object) -> None:
        if daemon is not None:
            daemon.request_reload()

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGTERM, signal.SIGINT)}
    previous[signal.SIGHUP] = signal.signal(signal.SIGHUP, reload)
    try:
        try:
            from stiction.daemon.service import Daemon

            daemon = Daemon(options_from_args(args))
            daemon.open()
        except StictionError as exc:
            print(f"stictiond: error: {exc}", file=sys.stderr)
            return 2
        if "stop" in asked:  # asked to stop while it was starting
            daemon.request_stop()
        try:
            return daemon.run()
        except StictionError as exc:
            print(f"stictiond: error: {exc}", file=sys.stderr)
            return 2
        finally:
            daemon.close()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


if __name__ == "__main__":
    sys.exit(main())
