"""CURVE keys for clients of a daemon that serves the network.

A daemon bound to anything but loopback or ipc:// is a CURVE server and talks
only to clients whose public keys it has authorised (docs/protocol.md,
"Security"). A client then needs the daemon's public key and its own key
pair, as zmq.auth certificate files (``stiction keys`` writes them).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zmq

from stiction.errors import StictionError


class CurveKeyError(StictionError):
    """A CURVE key file that cannot be used."""


@dataclass(frozen=True, slots=True)
class CurveKeys:
    server_public: bytes
    public: bytes
    secret: bytes

    @classmethod
    def from_files(cls, server_key: str | Path, client_secret_key: str | Path) -> CurveKeys:
        """``server_key``: the daemon's public ``.key`` file; ``client_secret_key``:
        this client's ``.key_secret`` file (its public key must be authorised
        on the daemon)."""
        from stiction.keyfiles import KeyFileError, load_certificate

        try:
            server_public, _ = load_certificate(server_key, secret=False)
            public, secret = load_certificate(client_secret_key, secret=True)
        except KeyFileError as exc:
            raise CurveKeyError(str(exc)) from None
        assert secret is not None
        return cls(server_public=server_public, public=public, secret=secret)

    def apply(self, sock: zmq.Socket[Any]) -> None:
        """Make ``sock`` a CURVE client of the daemon; call before connect()."""
        sock.curve_serverkey = self.server_public
        sock.curve_publickey = self.public
        sock.curve_secretkey = self.secret
