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


class AuthorizedKeys:
    """The clients' public keys in the authorised folder, each read by stiction's checked loader.

    zmq.auth's own folder loader opens every ``*.key`` as it is (a FIFO there
    blocked the daemon's start beyond SIGTERM) and drops the whole folder when
    one file is damaged, locking every client out. Here a file that is not a
    small regular key file is skipped with a warning naming it; the others
    stay authorised. ZeroMQ's ZAP thread asks `callback` about each peer.
    """

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.keys: frozenset[bytes] = frozenset()

    def reload(self) -> int:
        """Read the folder again; return how many keys are authorised now."""
        from stiction.keyfiles import KeyFileError, load_certificate

        keys: set[bytes] = set()
        try:
            paths = sorted(self.folder.glob("*.key"))
        except OSError as exc:
            log.warning("authorized_keys_unreadable folder=%s error=%s", self.folder, exc)
            return len(self.keys)  # keep the clients that were authorised
        for path in paths:
            try:
                public, _ = load_certificate(path, secret=False)
            except KeyFileError as exc:
                log.warning("authorized_key_skipped error=%s", exc)
                continue
            keys.add(public)
        self.keys = frozenset(keys)
        return len(keys)

    def callback(self, domain: str, key: bytes) -> bool:
        """ZAP: may the peer with this Z85 public key connect?"""
        return key in self.keys


class Guard:
    """Applies the policy to each socket before it binds."""

    def __init__(self, ctx: zmq.Context[Any], curve: CurveConfig) -> None:
        self.ctx = ctx
        self.curve = curve
        self._auth: Any = None
        self._authorized: AuthorizedKeys | None = None
        self._keys: tuple[bytes, bytes] | None = None
        # Keys that are given are checked now, not when an endpoint first needs
        # them: a typo in a key path on a loopback daemon was silently ignored
        # until the day the daemon was moved to a network address.
        if (curve.secret_key is None) != (curve.authorized_keys is None):
            raise SecurityError(
                "give both a CURVE secret key and a folder of authorised keys "
                "(--curve-secret-key and --curve-authorized, or [curve] secret_key and "
                "authorized_keys), or neither"
            )
        if curve.secret_key is not None:
            self._keys = self._load_server_keys()
        if curve.authorized_keys is not None and not curve.authorized_keys.is_dir():
            raise SecurityError(f"authorized_keys {curve.authorized_keys} is not a directory")

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
        assert self._keys is not None  # configured: loaded in __init__
        if self._auth is None:
            self._start_authenticator()
        public, secret = self._keys
        sock.zap_domain = ZAP_DOMAIN.encode()
        sock.curve_secretkey = secret
        sock.curve_publickey = public
        sock.curve_server = True

    def _load_server_keys(self) -> tuple[bytes, bytes]:
        from stiction.keyfiles import KeyFileError, load_certificate

        assert self.curve.secret_key is not None
        try:
            public, secret = load_certificate(self.curve.secret_key, secret=True)
        except KeyFileError as exc:
            raise SecurityError(str(exc)) from None
        assert secret is not None
        return public, secret

    def _start_authenticator(self) -> None:
        from zmq.auth.thread import ThreadAuthenticator

        keys_dir = self.curve.authorized_keys
        assert keys_dir is not None
        if not keys_dir.is_dir():
            raise SecurityError(f"authorized_keys {keys_dir} is not a directory")
        self._authorized = AuthorizedKeys(keys_dir)
        n = self._authorized.reload()
        auth = ThreadAuthenticator(self.ctx, log=logging.getLogger("stiction.daemon.zap"))
        auth.start()
        auth.configure_curve_callback(domain=ZAP_DOMAIN, credentials_provider=self._authorized)
        self._auth = auth
        log.info("curve enabled authorized_keys=%s clients=%d", keys_dir, n)

    def reload_keys(self) -> None:
        """Re-read the authorised keys (SIGHUP): added or removed clients take effect."""
        if self._authorized is not None:
            n = self._authorized.reload()
            log.info("curve reloaded authorized_keys=%s clients=%d", self._authorized.folder, n)

    def close(self) -> None:
        if self._auth is not None:
            self._auth.stop()
            self._auth = None
