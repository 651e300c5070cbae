"""ZeroMQ's own forwarder between daemons and renderers (XSUB -> XPUB).

The proxy connects its XSUB socket to every daemon's PUB endpoint and binds
one XPUB endpoint for subscribers; subscriptions flow upstream, so daemons
still send only what someone wants. zmq.proxy does the forwarding in C.
The bind side follows the daemon's rule (loopback, or CURVE); the connect
side can authenticate to CURVE daemons with a client key.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import zmq

from stiction.daemon.security import CurveConfig, Guard, SecurityError

log = logging.getLogger("stiction.daemon.proxy")


def _load(path: Path, *, secret: bool = False) -> tuple[bytes, bytes | None]:
    from stiction.keyfiles import KeyFileError, load_certificate

    try:
        return load_certificate(path, secret=secret)
    except KeyFileError as exc:
        raise SecurityError(str(exc)) from None


def run_proxy(
    ctx: zmq.Context[Any],
    frontends: list[str],
    backend: str,
    curve: CurveConfig,
    client_key: Path | None = None,
    server_keys: list[Path] | None = None,
) -> int:
    """Forward until the context is terminated or the process is interrupted."""
    server_keys = server_keys or []
    if server_keys and len(server_keys) != len(frontends):
        raise SecurityError("give one --server-key per --frontend (or none)")
    guard = Guard(ctx, curve)
    xsub = ctx.socket(zmq.XSUB)
    xpub = ctx.socket(zmq.XPUB)
    xsub.linger = xpub.linger = 0
    try:
        guard.bind(xpub, backend, "proxy backend")
        for i, endpoint in enumerate(frontends):
            if server_keys:
                if client_key is None:
                    raise SecurityError("--server-key needs --client-key (this proxy's key pair)")
                public, secret = _load(client_key, secret=True)
                assert secret is not None
                xsub.curve_publickey = public
                xsub.curve_secretkey = secret
                xsub.curve_serverkey = _load(server_keys[i])[0]
            xsub.connect(endpoint)
        log.info("proxy frontends=%s backend=%s", ",".join(frontends), backend)
        zmq.proxy(xsub, xpub)
    except zmq.ContextTerminated:
        pass
    finally:
        xsub.close(linger=0)
        xpub.close(linger=0)
        guard.close()
    return 0
