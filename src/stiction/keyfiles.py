"""CURVE key files: written private from the start, refused when others can read them.

A secret key that another user can read lets them impersonate the daemon
(or a client) to every peer; like ssh with a private key, stiction refuses
to use one whose mode gives group or others any access, and names the fix.
"""

from __future__ import annotations

import os
import re
import stat
import tempfile
from pathlib import Path

from stiction.errors import StictionError
from stiction.userfiles import read_regular_text, shown

MAX_KEY_FILE_BYTES = 64 << 10
"""A zmq.auth certificate is a few hundred bytes; anything far larger is not one."""

_NAME = re.compile(r"[A-Za-z0-9_\-][A-Za-z0-9_.\-]{0,63}")
"""A key pair's name: a plain file name. An empty name wrote the hidden files
.key and .key_secret; one with '/' wrote elsewhere or failed with a confusing
'cannot write keys to DIR'."""

_Z85 = frozenset(
    "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ.-:+=^!/*?&<>()[]{}@%$#"
)
"""The Z85 alphabet (ZeroMQ RFC 32), in which a 32-byte CURVE key is 40 characters."""


class KeyFileError(StictionError):
    """A key file that cannot be written or must not be used."""


def check_private(path: str | Path) -> None:
    """Raise unless `path` is a file only its owner can read or write."""
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except OSError as exc:
        raise KeyFileError(f"cannot read CURVE key {p}: {exc.strerror or exc}") from None
    if mode & 0o077:
        raise KeyFileError(
            f"{p} can be read by other users (mode {stat.S_IMODE(mode):04o}); a secret key "
            f"must be private: run `chmod 600 {p}`"
        )


def load_certificate(path: str | Path, *, secret: bool) -> tuple[bytes, bytes | None]:
    """(public, secret) from a zmq.auth key file, or one KeyFileError saying what is wrong.

    zmq.auth.load_certificate opens whatever it is given (a FIFO blocks it
    forever) and returns keys unchecked, so a damaged key surfaced later as
    a bare ZMQError from setsockopt. Here the file must be a small regular
    file and each key 40 Z85 characters; with `secret`, it must hold a
    secret key that only its owner can read.
    """
    import zmq.auth

    p = Path(path)
    read_regular_text(p, MAX_KEY_FILE_BYTES, KeyFileError, "CURVE key file")
    try:
        public, secret_key = zmq.auth.load_certificate(str(p))
    except (OSError, ValueError) as exc:
        raise KeyFileError(
            f"{shown(p)}: not a CURVE key file ({exc}); `stiction keys DIR NAME` makes a pair"
        ) from None
    for what, key in (("public", public), ("secret", secret_key)):
        if key is not None and (len(key) != 40 or not set(key.decode("latin-1")) <= _Z85):
            raise KeyFileError(
                f"{shown(p)}: its {what} key is not 40 Z85 characters; the file is damaged "
                "(`stiction keys DIR NAME` makes a new pair)"
            )
    if secret:
        if not secret_key:
            raise KeyFileError(f"{shown(p)} holds no secret key (give the .key_secret file)")
        check_private(p)
    return public, secret_key


def write_keypair(directory: Path, name: str, force: bool = False) -> tuple[Path, Path]:
    """DIR/NAME.key (public) and DIR/NAME.key_secret (mode 0600), each written whole or not at all.

    The pair is made in a private temporary folder inside DIR (so the final
    rename stays on one file system and is atomic) under a 077 umask: the
    secret file is never readable by others, not even for an instant.
    """
    import zmq.auth

    if not _NAME.fullmatch(name):
        raise KeyFileError(
            f"key name {shown(repr(name))}: use 1-64 letters, digits, '-', '_' or '.', not "
            "starting with '.' (it names the files NAME.key and NAME.key_secret in DIR)"
        )
    if directory.exists() and not directory.is_dir():  # mkdir said only "File exists"
        raise KeyFileError(f"{shown(directory)} is not a folder; give the folder for the keys")
    public = directory / f"{name}.key"
    secret = directory / f"{name}.key_secret"
    if not force:
        for p in (public, secret):
            if p.exists():
                raise KeyFileError(f"{p} exists; pass --force to replace the key pair")
    try:
        directory.mkdir(parents=True, exist_ok=True)
        old = os.umask(0o077)
        try:
            tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=directory))
            try:
                made_public, made_secret = (
                    Path(f) for f in zmq.auth.create_certificates(str(tmp), name)
                )
                os.chmod(made_secret, 0o600)
                os.chmod(made_public, 0o644)  # the public half is meant to be copied
                for f in (made_public, made_secret):
                    fd = os.open(f, os.O_RDONLY)
                    try:
                        os.fsync(fd)
                    finally:
                        os.close(fd)
                os.replace(made_secret, secret)
                os.replace(made_public, public)
            finally:
                for leftover in tmp.iterdir():
                    leftover.unlink()
                tmp.rmdir()
        finally:
            os.umask(old)
    except OSError as exc:
        raise KeyFileError(f"cannot write keys to {directory}: {exc.strerror or exc}") from None
    return public, secret
