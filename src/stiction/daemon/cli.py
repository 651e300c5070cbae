"""`stiction proxy` (many daemons to many renderers) and `stiction keys` (CURVE key pairs)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from stiction.argtypes import endpoint


def _proxy(args: argparse.Namespace) -> int:
    import zmq

    from stiction.daemon.proxy import run_proxy
    from stiction.daemon.security import CurveConfig

    curve = CurveConfig(
        secret_key=args.curve_secret_key,
        authorized_keys=args.curve_authorized,
        required=args.curve_required,
    )
    try:
        return run_proxy(
            zmq.Context.instance(),
            list(args.frontend),
            args.backend,
            curve,
            client_key=args.client_key,
            server_keys=list(args.server_key or []),
        )
    except KeyboardInterrupt:
        return 0


def _keys(args: argparse.Namespace) -> int:
    import zmq.auth

    from stiction.keyfiles import write_keypair

    public_file, secret_file = write_keypair(args.directory, args.name, args.force)
    public, _ = zmq.auth.load_certificate(str(public_file))
    print(f"public key file (copy to peers): {public_file}")
    print(f"secret key file (keep private, mode 0600):  {secret_file}")
    print(f"public key (Z85): {public.decode()}")
    return 0


def register(sub: argparse._SubParsersAction[Any]) -> None:
    p = sub.add_parser(
        "proxy",
        help="forward frames from daemons to subscribers (ZeroMQ XSUB/XPUB)",
        description="Connect to one or more stictiond publishers and republish everything on "
        "one endpoint, so many renderers can subscribe to many daemons (docs/daemon.md).",
    )
    p.add_argument(
        "--frontend",
        action="append",
        type=endpoint,
        required=True,
        metavar="ENDPOINT",
        help="a daemon's pub endpoint to connect to (repeatable)",
    )
    p.add_argument(
        "--backend", required=True, type=endpoint, metavar="ENDPOINT", help="endpoint to bind"
    )
    p.add_argument(
        "--client-key", type=Path, metavar="FILE", help="this proxy's .key_secret for CURVE daemons"
    )
    p.add_argument(
        "--server-key",
        action="append",
        type=Path,
        metavar="FILE",
        help="a daemon's public .key, in the order of --frontend (CURVE daemons)",
    )
    p.add_argument(
        "--curve-secret-key", type=Path, metavar="FILE", help="the backend's .key_secret"
    )
    p.add_argument("--curve-authorized", type=Path, metavar="DIR", help="authorised client keys")
    p.add_argument("--curve-required", action="store_true", help="CURVE on loopback too")
    p.set_defaults(func=_proxy)

    k = sub.add_parser(
        "keys",
        help="make a CURVE key pair for stictiond, a proxy or a client",
        description="Writes DIR/NAME.key (public: copy it to peers) and DIR/NAME.key_secret "
        "(keep private), in zmq.auth's certificate format.",
    )
    k.add_argument("directory", type=Path, metavar="DIR")
    k.add_argument("name", metavar="NAME")
    k.add_argument("--force", action="store_true", help="replace an existing key pair of that name")
    k.set_defaults(func=_keys)
