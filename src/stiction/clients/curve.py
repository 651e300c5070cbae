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
        import zmq.auth

        from stiction.keyfiles import KeyFileError, check_private

        try:
            server_public, _ = zmq.auth.load_certificate(str(server_key))
            public, secret = zmq.auth.load_certificate(str(client_secret_key))
        except (OSError, ValueError) as exc:
            raise CurveKeyError(f"cannot read CURVE key: {exc}") from None
        if not secret:
            raise CurveKeyError(
                f"{client_secret_key} holds no secret key (give the client's .key_secret file)"
            )
        try:
            check_private(client_secret_key)
        except KeyFileError as exc:
            raise CurveKeyError(str(exc)) from None
        return cls(server_public=server_public, public=public, secret=secret)

    def apply(self, sock: zmq.Socket[Any]) -> None:
        """Make ``sock`` a CURVE client of the daemon; call before connect()."""
        sock.curve_serverkey = self.server_public
        sock.curve_publickey = self.public
        sock.curve_secretkey = self.secret
