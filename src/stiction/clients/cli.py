"""`stiction listen | record | replay | web`: the client tools on the command line.

Handlers import their modules when they run, so `stiction --help` does not
load numpy or aiohttp.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from stiction import protocol
from stiction.argtypes import (
    endpoint,
    factor,
    http_host,
    non_negative_int,
    port,
    positive_int,
    seconds,
)
from stiction.errors import StictionError


def default_control(pub: str) -> str | None:
    """The control endpoint that goes with a publisher endpoint, when it is the default."""
    return protocol.DEFAULT_CONTROL if pub == protocol.DEFAULT_PUB else None


def _curve(args: argparse.Namespace) -> Any:
    """CurveKeys from --curve-server-key / --curve-client-key, or None."""
    server, client = args.curve_server_key, args.curve_client_key
    if server is None and client is None:
        return None
    if server is None or client is None:
        raise StictionError("give both --curve-server-key and --curve-client-key, or neither")
    from stiction.clients.curve import CurveKeys

    return CurveKeys.from_files(server, client)


def _add_curve(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--curve-server-key", metavar="FILE", help="the daemon's public .key (network daemons)"
    )
    p.add_argument(
        "--curve-client-key", metavar="FILE", help="this client's .key_secret (network daemons)"
    )


def _listen(args: argparse.Namespace) -> int:
    from stiction.clients.listen import listen

    return listen(
        args.endpoint,
        as_json=args.json,
        count=args.count,
        seconds=args.seconds,
        devices=args.device or None,
        scenes=args.scenes,
        curve=_curve(args),
        control=None if args.no_control else (args.control or default_control(args.endpoint)),
    )


def _record(args: argparse.Namespace) -> int:
    from stiction.clients.record import (
        NothingRecorded,
        record,
        recover_spool,
        report,
        stop_on_signals,
    )

    if args.recover:
        return recover_spool(args.recover, args.out, args.force)
    if not args.out:
        print("stiction record: error: --out FILE.npz is required", file=sys.stderr)
        return 2
    ctl = None if args.no_control else (args.control or default_control(args.endpoint))
    with stop_on_signals() as stop:
        try:
            result = record(
                args.endpoint,
                args.out,
                control_endpoint=ctl,
                count=args.count,
                seconds=args.seconds,
                idle=args.idle,
                devices=args.device or None,
                stop=stop,
                curve=_curve(args),
                force=args.force,
            )
        except NothingRecorded as exc:  # not a usage error: the session itself was empty
            print(f"stiction record: {exc}", file=sys.stderr)
            return 1
    report(result)
    return 0


def _replay(args: argparse.Namespace) -> int:
    from stiction.clients.replay import replay

    return replay(
        args.file,
        pub=args.pub,
        control=args.control,
        speed=args.speed,
        fast=args.fast,
        loops=args.loop,
        wait=args.wait,
        no_wait=args.no_wait,
        hold=args.hold,
    )


def _web(args: argparse.Namespace) -> int:
    from stiction.clients.web.server import serve

    ctl = None if args.no_control else (args.control or default_control(args.pub))
    return serve(
        pub=args.pub,
        control=ctl,
        host=args.host,
        port=args.port,
        seconds=args.seconds,
        curve=_curve(args),
        token=args.token,
        allow_origins=tuple(args.allow_origin or ()),
    )


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add listen, record, replay and web."""
    p = sub.add_parser(
        "listen",
        help="print the frames a subscriber receives",
        description="Subscribe to a daemon and print its frames, one line each.",
    )
    p.add_argument(
        "endpoint",
        nargs="?",
        type=endpoint,
        default=protocol.DEFAULT_PUB,
        help="publisher endpoint",
    )
    p.add_argument("--json", action="store_true", help="one JSON object per frame: the wire frame")
    p.add_argument("--count", type=positive_int, help="stop after N frames")
    p.add_argument("--seconds", type=seconds, help="stop after S seconds")
    p.add_argument("--device", action="append", help="only this device (repeatable)")
    p.add_argument("--scenes", action="store_true", help="also print scene messages")
    p.add_argument(
        "--control",
        type=endpoint,
        help="daemon control endpoint, asked why no frame came "
        f"(default: {protocol.DEFAULT_CONTROL} when the endpoint is the default)",
    )
    p.add_argument("--no-control", action="store_true", help="do not contact the control endpoint")
    _add_curve(p)
    p.set_defaults(func=_listen)

    p = sub.add_parser(
        "record",
        help="record the frame stream to a .npz file",
        description="Record frames (and scene changes) to a numpy .npz file with the scene "
        "and parameters in its metadata. Stops at --count, --seconds, --idle, Ctrl-C or SIGTERM; "
        "the file is written in every case.",
    )
    p.add_argument(
        "endpoint",
        nargs="?",
        type=endpoint,
        default=protocol.DEFAULT_PUB,
        help="publisher endpoint",
    )
    p.add_argument("--out", help="output file, *.npz (required unless --recover)")
    p.add_argument(
        "--recover",
        metavar="SPOOL",
        help="turn the FILE.npz.partial spool a killed recorder left into its recording "
        "(--out: where to write it; default: the name it was recording to)",
    )
    p.add_argument("--force", action="store_true", help="replace --out if it exists")
    p.add_argument(
        "--control",
        type=endpoint,
        help="control endpoint for scene and parameters "
        f"(default: {protocol.DEFAULT_CONTROL} when ENDPOINT is the default)",
    )
    p.add_argument("--no-control", action="store_true", help="do not contact the control endpoint")
    p.add_argument("--count", type=positive_int, help="stop after N frames")
    p.add_argument("--seconds", type=seconds, help="stop after S seconds")
    p.add_argument(
        "--idle",
        type=seconds,
        help="stop after S seconds without frames (once started; a quiet daemon still sends "
        "a keep-alive frame a second, so S > 1 means the daemon stopped)",
    )
    p.add_argument("--device", action="append", help="only this device (repeatable)")
    _add_curve(p)
    p.set_defaults(func=_record)

    p = sub.add_parser(
        "replay",
        help="publish a recording again",
        description="Publish a recording made by `stiction record` as a daemon would, at the "
        "recorded pace (scaled by --speed) or as fast as possible (--fast).",
    )
    p.add_argument("file", help="a .npz recording")
    p.add_argument(
        "--pub", type=endpoint, default=protocol.DEFAULT_PUB, help="endpoint to publish on"
    )
    p.add_argument(
        "--control",
        type=endpoint,
        help="also answer read-only control requests (snapshot, get_scene) here",
    )
    p.add_argument("--speed", type=factor, default=1.0, help="pace factor (default 1)")
    p.add_argument("--fast", action="store_true", help="as fast as possible")
    p.add_argument("--loop", type=non_negative_int, default=1, help="passes to play (0: forever)")
    p.add_argument("--wait", type=seconds, help="give up if no subscriber comes within S seconds")
    p.add_argument("--no-wait", action="store_true", help="start without waiting for a subscriber")
    p.add_argument(
        "--hold",
        nargs="?",
        type=seconds,
        const=float("inf"),
        help="after the end, keep answering control requests (for S seconds, or until Ctrl-C)",
    )
    p.set_defaults(func=_replay)

    p = sub.add_parser(
        "web",
        help="watch the frames in a browser",
        description="Serve a page that draws the scene, the pointer and the virtual string "
        "from the daemon's frames, forwarded over a WebSocket.",
    )
    p.add_argument(
        "--pub", type=endpoint, default=protocol.DEFAULT_PUB, help="daemon publisher endpoint"
    )
    p.add_argument(
        "--control",
        type=endpoint,
        help="daemon control endpoint, for the scene "
        f"(default: {protocol.DEFAULT_CONTROL} when --pub is the default)",
    )
    p.add_argument("--no-control", action="store_true", help="do not contact the control endpoint")
    p.add_argument(
        "--host",
        type=http_host,
        default="127.0.0.1",
        help="address to serve on (default loopback; any other needs the access token, "
        "generated and printed with the URL unless --token gives one)",
    )
    p.add_argument("--token", help="the access token for a non-loopback --host")
    p.add_argument(
        "--allow-origin",
        action="append",
        metavar="ORIGIN",
        help="also accept WebSockets from this page origin, e.g. https://lab.example (repeatable)",
    )
    p.add_argument("--port", type=port, default=8765, help="HTTP port (0: any free port)")
    p.add_argument("--seconds", type=seconds, help="stop after S seconds (for scripts)")
    _add_curve(p)
    p.set_defaults(func=_web)
