"""Who may talk to the daemon: loopback freely, the network only with CURVE.

A pen's position is personal input, so the daemon never listens on a network
address in clear text. Binding anything but loopback or ipc:// requires a
CURVE secret key and a directory of authorised client public keys; ZeroMQ's
ZAP authenticator (zmq.auth) then refuses every peer whose key is not in it,
before a single message of theirs is read.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zmq

from stiction.errors import StictionError
from stiction.protocol import is_local_endpoint

log = logging.getLogger("stiction.daemon.security")

ZAP_DOMAIN = "stiction"


class SecurityError(StictionError):
    """An endpoint or key setting that would expose the daemon, or unreadable keys."""


@dataclass(frozen=True, slots=True)
class CurveConfig:
    """`secret_key`: the daemon's zmq.auth ``.key_secret`` file; `authorized_keys`:
    a directory of clients' ``.key`` files. `required` forces CURVE on every
    endpoint, loopback included."""

    secret_key: Path | None = None
    authorized_keys: Path | None = None
    required: bool = False

    @property
    def configured(self) -> bool:
        return self.secret_key is not None and self.authorized_keys is not None


class Guard:
    """Applies the policy to each socket before it binds."""

    def __init__(self, ctx: zmq.Context[Any], curve: CurveConfig) -> None:
        self.ctx = ctx
        self.curve = curve
        self._auth: Any = None
        self._keys: tuple[bytes, bytes] | None = None

    def bind(self, sock: zmq.Socket[Any], endpoint: str, what: str) -> None:
        local = is_local_endpoint(endpoint)
        if not local or self.curve.required:
            if not self.curve.configured:
                raise SecurityError(
                    f"{what} endpoint {endpoint} is not loopback: binding it needs CURVE keys "
                    "(--curve-secret-key and --curve-authorized, or [curve] in the config; "
                    "`stiction keys` makes them, docs/daemon.md shows how)"
                )
            self._apply_curve(sock)
        try:
            sock.bind(endpoint)
        except zmq.ZMQError as exc:
            raise SecurityError(f"cannot bind {what} endpoint {endpoint}: {exc}") from None

    def _apply_curve(self, sock: zmq.Socket[Any]) -> None:
        if self._keys is None:
            self._keys = self._load_server_keys()
            self._start_authenticator()
        public, secret = self._keys
        sock.zap_domain = ZAP_DOMAIN.encode()
        sock.curve_secretkey = secret
        sock.curve_publickey = public
        sock.curve_server = True

    def _load_server_keys(self) -> tuple[bytes, bytes]:
        import zmq.auth

        from stiction.keyfiles import KeyFileError, check_private

        assert self.curve.secret_key is not None
        try:
            public, secret = zmq.auth.load_certificate(str(self.curve.secret_key))
        except (OSError, ValueError) as exc:
            raise SecurityError(f"cannot read CURVE key {self.curve.secret_key}: {exc}") from None
        if not secret:
            raise SecurityError(
                f"{self.curve.secret_key} holds no secret key (use the .key_secret file)"
            )
        try:
            check_private(self.curve.secret_key)
        except KeyFileError as exc:
            raise SecurityError(str(exc)) from None
        return public, secret

    def _start_authenticator(self) -> None:
        from zmq.auth.thread import ThreadAuthenticator

        keys_dir = self.curve.authorized_keys
        assert keys_dir is not None
        if not keys_dir.is_dir():
            raise SecurityError(f"authorized_keys {keys_dir} is not a directory")
        auth = ThreadAuthenticator(self.ctx, log=logging.getLogger("stiction.daemon.zap"))
        auth.start()
        auth.configure_curve(domain=ZAP_DOMAIN, location=str(keys_dir))
        self._auth = auth
        n = len(list(keys_dir.glob("*.key")))
        log.info("curve enabled authorized_keys=%s clients=%d", keys_dir, n)

    def reload_keys(self) -> None:
        """Re-read the authorised keys (SIGHUP): added or removed clients take effect."""
        if self._auth is not None and self.curve.authorized_keys is not None:
            self._auth.configure_curve(domain=ZAP_DOMAIN, location=str(self.curve.authorized_keys))

    def close(self) -> None:
        if self._auth is not None:
            self._auth.stop()
            self._auth = None
