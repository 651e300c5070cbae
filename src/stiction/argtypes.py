"""Argument types shared by `stictiond` and every `stiction` subcommand.

Each is an argparse ``type=``: a bad value raises ``ArgumentTypeError``, which
argparse prints as ``PROG: error: argument --FLAG: MESSAGE`` with the usage
line and exit status 2, so every command checks a flag the same way and names
it. Kept free of heavy imports: argument errors must not load zmq or numpy.
"""

from __future__ import annotations

import argparse
import ipaddress
import math
import re
from collections.abc import Callable

SCHEMES = ("tcp", "ipc", "inproc", "ws", "wss")


def _int(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def _float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """A whole number > 0 (counts, high-water marks)."""
    value = _int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def non_negative_int(text: str) -> int:
    """A whole number >= 0, where 0 has a documented meaning (e.g. `--loop 0`: forever)."""
    value = _int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must not be negative, got {value}")
    return value


def finite_float(text: str) -> float:
    """Any finite number (a position, an offset): NaN and infinities are refused."""
    return _float(text)


def positive_float(text: str) -> float:
    """A finite number > 0 (seconds, rates, factors)."""
    value = _float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def non_negative_float(text: str) -> float:
    """A finite number >= 0, where 0 has a documented meaning (e.g. `--keepalive 0`)."""
    value = _float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must not be negative, got {text}")
    return value


MAX_SECONDS = 1e9
"""Any duration a flag or config key gives: some 31 years, longer than any run,
and still a number that poll() (milliseconds in a C long) and thread waits
accept; 1e300 s made ZeroMQ's poll raise OverflowError."""

MAX_HWM = 2**31 - 1
"""A ZeroMQ high-water mark is a C int; a larger one made setsockopt raise."""


def count_up_to(high: int) -> Callable[[str], int]:
    """A whole number from 1 to `high` (a count with a ceiling)."""

    def check(text: str) -> int:
        value = positive_int(text)
        if value > high:
            raise argparse.ArgumentTypeError(f"must be at most {high}, got {value}")
        return value

    check.__name__ = f"count up to {high}"
    return check


hwm = count_up_to(MAX_HWM)
"""A ZeroMQ high-water mark: a whole number from 1 to MAX_HWM."""


def seconds(text: str) -> float:
    """A duration in seconds: finite, > 0, at most MAX_SECONDS."""
    value = positive_float(text)
    if value > MAX_SECONDS:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_SECONDS:g} seconds, got {text}")
    return value


def seconds_or_zero(text: str) -> float:
    """A duration in seconds where 0 has a documented meaning: finite, 0 to MAX_SECONDS."""
    value = non_negative_float(text)
    if value > MAX_SECONDS:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_SECONDS:g} seconds, got {text}")
    return value


MAX_FACTOR = 1e6
"""A pace factor (`--speed`) from 1/MAX_FACTOR to MAX_FACTOR: a million times
slower still replays an hour's pause as a wait poll() can hold; 1e-300 raised
OverflowError there."""


def factor(text: str) -> float:
    """A pace factor: finite, from 1/MAX_FACTOR to MAX_FACTOR."""
    value = positive_float(text)
    if not 1 / MAX_FACTOR <= value <= MAX_FACTOR:
        raise argparse.ArgumentTypeError(
            f"must be from {1 / MAX_FACTOR:g} to {MAX_FACTOR:g}, got {text}"
        )
    return value


SIZE_MM_FLAG = "--size-mm WxH (e.g. --size-mm 254x158.8)"
"""How a command line that reads a device gives its size: in millimetres, the unit in the flag."""


def size_mm(text: str) -> tuple[float, float]:
    """`WxH`: an active area in millimetres, both finite, from 1 mm to 10 m (a
    smaller one is a typo that scaled the pointer to 1e304 px)."""
    w, sep, h = text.lower().partition("x")
    try:
        size = (float(w), float(h))
    except ValueError:
        size = (math.nan, math.nan)
    if not sep or not all(math.isfinite(v) and 1 <= v <= 10_000 for v in size):
        raise argparse.ArgumentTypeError(
            "expected the active area as WIDTHxHEIGHT in millimetres (1 to 10000), "
            f"e.g. 254x158.8, got {text!r}"
        )
    return size


def size_m(text: str) -> tuple[float, float]:
    """`WxH` in millimetres, returned in metres (what the HID factories take)."""
    w, h = size_mm(text)
    return w / 1000.0, h / 1000.0


def add_size_mm_option(
    parser: argparse.ArgumentParser, *, metres: bool = False, when: str = "if not reported"
) -> None:
    """`--size-mm WxH` (old name `--size`) into `args.size`, in mm or metres; and
    `size_how`, so that a missing size is reported naming this flag."""
    parser.add_argument(
        "--size-mm",
        "--size",
        dest="size",
        type=size_m if metres else size_mm,
        metavar="WxH",
        help=f"active area in mm, {when} (--size: the old name)",
    )
    parser.set_defaults(size_how=SIZE_MM_FLAG)


def int_range(low: int, high: int) -> Callable[[str], int]:
    """A whole number in [low, high] (a priority, a port)."""

    def check(text: str) -> int:
        value = _int(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be {low} to {high}, got {value}")
        return value

    check.__name__ = f"int {low}-{high}"
    return check


def port(text: str) -> int:
    """A TCP port, 0 (any free port) to 65535."""
    value = _int(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"not a TCP port (0-65535): {value}")
    return value


_HOSTNAME = re.compile(r"[A-Za-z0-9_](?:[A-Za-z0-9_.\-]{0,252})")
"""A host or interface name (tablet-pc, localhost, eth0) as libzmq resolves it."""


def _check_host(text: str, host: str) -> None:
    """Refuse a host libzmq would take and fail on later, or never reach.

    `tcp://[::1:5556` and `tcp://1.2.3.4.5:1` passed before: a connect to
    them is silently retried forever, so `stiction listen` just waited.
    """
    if host == "*":
        return
    if host.startswith("[") or host.endswith("]"):
        inner = host[1:-1] if host.startswith("[") and host.endswith("]") else None
        try:
            ipaddress.IPv6Address(inner.split("%", 1)[0] if inner else "")
        except ValueError:
            raise ValueError(f"{text!r}: {host!r} is not an IPv6 address in brackets") from None
        return
    if ":" in host:
        raise ValueError(f"{text!r}: write an IPv6 address in brackets, e.g. tcp://[::1]:5556")
    if all(c.isdigit() or c == "." for c in host):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise ValueError(f"{text!r}: {host!r} is not an IPv4 address") from None
        return
    if not _HOSTNAME.fullmatch(host):
        raise ValueError(f"{text!r}: {host!r} is not a host name, an address or *")


def http_host(text: str) -> str:
    """An address to serve HTTP on (`stiction web --host`): a host name, an IPv4
    address, or an IPv6 address with or without its URL brackets (`[::1]` is
    served as `::1`; aiohttp, like getaddrinfo, takes the bare form)."""
    if text == "":
        return text  # every interface, as aiohttp reads it
    bare = text[1:-1] if text.startswith("[") and text.endswith("]") else text
    if bare == "*":
        raise argparse.ArgumentTypeError(
            "'*' is ZeroMQ's wildcard; to serve on every interface give 0.0.0.0 or ::"
        )
    if ":" in bare:
        try:
            ipaddress.IPv6Address(bare.split("%", 1)[0])
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an IPv6 address") from None
        return bare
    try:
        _check_host(text, bare)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a host name or an IPv4 or IPv6 address"
        ) from None
    return bare


def check_endpoint(text: str) -> str:
    """Return the ZeroMQ endpoint `text`, or raise ValueError saying what is wrong with it.

    libzmq itself accepts some of these mistakes (a port above 65535 binds a
    random port) or reports them as something else, so they are caught here.
    """
    scheme, sep, rest = text.partition("://")
    if not sep or scheme not in SCHEMES:
        raise ValueError(
            f"not a ZeroMQ endpoint: {text!r} (expected tcp://HOST:PORT, ipc://PATH or "
            "inproc://NAME)"
        )
    if not rest:
        raise ValueError(f"{text!r} has nothing after {scheme}://")
    if scheme in ("tcp", "ws", "wss"):
        hostport = rest.split("/", 1)[0] if scheme != "tcp" else rest
        host, colon, porttext = hostport.rpartition(":")
        if not colon or not host:
            raise ValueError(f"{text!r} needs HOST:PORT after {scheme}://")
        _check_host(text, host)
        if porttext != "*":
            try:
                value = int(porttext)
            except ValueError:
                raise ValueError(f"{text!r}: port {porttext!r} is not a number or *") from None
            if not 1 <= value <= 65535:
                raise ValueError(f"{text!r}: port {value} is out of range (1-65535, or *)")
    return text


def endpoint(text: str) -> str:
    """A ZeroMQ endpoint flag (`--pub`, `--control`, ...)."""
    try:
        return check_endpoint(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
