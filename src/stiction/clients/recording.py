"""The recording file: a numpy ``.npz`` that analysis reads directly and replay
publishes again.

Why .npz rather than Parquet: the experiment analysis this serves is numpy
code (release times, string lengths, trajectories per trial), numpy is already
a dependency while pyarrow would add ~100 MB, and ``np.load`` needs nothing
else. Every array is numeric or fixed-width unicode, so loading never needs
``allow_pickle`` (a recording from someone else cannot run code).

Contents (all arrays; see docs/clients.md for the table):

- the ContactTable columns (``frame_*``: one row per frame; the rest: one row
  per contact, ``contact_frame`` linking a contact to its frame);
- ``messages`` (uint8), ``message_offsets`` (int64, n+1), ``message_topics``,
  ``message_recv_t``: every received message (frames and scene changes) as its
  msgpack payload, in order, so replay reproduces the stream with every key,
  including keys this version of stiction does not know;
- ``meta``: one JSON string: format and schema versions, endpoints, start
  time, and the scene and parameters fetched from the control endpoint.

``write`` builds a file from messages held in memory. ``stiction record``
does not use it: it streams the same arrays from its spool (spool.py), and
the tests check the two files are equal.
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import numpy.typing as npt

from stiction import protocol
from stiction.clients.columns import ContactTable
from stiction.clients.messages import Frame, parse_message
from stiction.errors import ProtocolError, RecordingError
from stiction.userfiles import open_regular, shown

FORMAT = "stiction-recording"
FORMAT_VERSION = 1

MAX_NPZ_BYTES = 4 << 30
"""A recording, both as a file and with its arrays uncompressed: one pen at 100 Hz
takes about 740 bytes a frame (a 5 s `stiction record` of synthetic:demo), so
this is some 15 hours. A .npz is a zip, and a few megabytes of zip can claim
terabytes of arrays; the claim is checked before anything is inflated."""


@dataclass(frozen=True)
class Recording:
    """A loaded recording: the columns, the raw message stream and the metadata."""

    table: ContactTable
    meta: dict[str, Any]
    payloads: npt.NDArray[np.uint8]
    offsets: npt.NDArray[np.int64]
    topics: npt.NDArray[np.str_]
    recv_t: npt.NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.topics.shape[0])

    def messages(self) -> Iterator[tuple[bytes, bytes]]:
        """(topic, payload) of every recorded message, in the order received."""
        buf = self.payloads.tobytes()
        for i, topic in enumerate(self.topics.tolist()):
            yield topic.encode("utf-8"), buf[int(self.offsets[i]) : int(self.offsets[i + 1])]

    def frames(self) -> Iterator[Frame]:
        for topic, payload in self.messages():
            msg = parse_message(topic, payload)
            if isinstance(msg, Frame):
                yield msg


def meta_json(meta: dict[str, Any], *, frames: int, messages: int) -> str:
    """The ``meta`` array's JSON: the format markers around the recorder's metadata.
    One place for it, as the spool (spool.py) assembles files without write()."""
    full_meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "schema_version": protocol.SCHEMA_VERSION,
        **meta,
        "frames": frames,
        "messages": messages,
    }
    return json.dumps(full_meta, allow_nan=False, default=str)


def write(
    path: str | Path,
    messages: list[tuple[bytes, bytes, float]],
    frames: list[Frame],
    meta: dict[str, Any],
) -> Path:
    """Write atomically (temp file, then rename): an interrupted write never
    leaves a truncated recording under the requested name."""
    path = Path(path)
    if path.suffix != ".npz":
        raise RecordingError(f"{path}: recordings are numpy .npz files; name it *.npz")
    table = ContactTable.from_frames(frames)
    sizes = np.fromiter((len(p) for _, p, _ in messages), dtype=np.int64, count=len(messages))
    offsets = np.zeros(len(messages) + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    payloads = np.frombuffer(b"".join(p for _, p, _ in messages), dtype=np.uint8)
    arrays: dict[str, Any] = {
        **table.as_dict(),
        "messages": payloads,
        "message_offsets": offsets,
        "message_topics": np.asarray(
            [t.decode("utf-8", "replace") for t, _, _ in messages], dtype=np.str_
        ),
        "message_recv_t": np.asarray([r for _, _, r in messages], dtype=np.float64),
        "meta": np.asarray(meta_json(meta, frames=len(frames), messages=len(messages))),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _arrays() -> tuple[str, ...]:
    """The arrays every recording holds."""
    return (
        "meta",
        *ContactTable.__dataclass_fields__,
        "messages",
        "message_offsets",
        "message_topics",
        "message_recv_t",
    )


def read(path: str | Path) -> Recording:
    """Load a recording; a file that is not one raises RecordingError naming it."""
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{shown(path)}: no such file")
    with open_regular(path, MAX_NPZ_BYTES, RecordingError, "recording") as fh:
        return _read(fh, path)


def _read(fh: BinaryIO, path: Path) -> Recording:
    if not zipfile.is_zipfile(fh):
        raise RecordingError(
            f"{shown(path)}: not a numpy .npz recording (not a zip file; stiction never "
            "loads pickled data)"
        )
    fh.seek(0)
    try:
        with zipfile.ZipFile(fh) as zf:
            expanded = sum(info.file_size for info in zf.infolist())
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise RecordingError(f"{shown(path)}: not a numpy .npz recording ({exc})") from None
    if expanded > MAX_NPZ_BYTES:
        raise RecordingError(
            f"{shown(path)}: its arrays would take {expanded} bytes; a recording is at most "
            f"{MAX_NPZ_BYTES} (stiction.clients.recording.MAX_NPZ_BYTES)"
        )
    fh.seek(0)
    try:
        data = np.load(fh, allow_pickle=False)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise RecordingError(f"{shown(path)}: not a numpy .npz recording ({exc})") from None
    with data:
        try:
            meta = json.loads(str(data["meta"]))
            if not isinstance(meta, dict) or meta.get("format") != FORMAT:
                raise RecordingError(f"{path}: not a stiction recording (no format marker)")
            if int(meta.get("format_version", 0)) > FORMAT_VERSION:
                raise RecordingError(
                    f"{path}: recording format {meta['format_version']} is newer than this "
                    f"stiction's {FORMAT_VERSION}; upgrade stiction to read it"
                )
            columns = {name: data[name] for name in ContactTable.__dataclass_fields__}
            rec = Recording(
                table=ContactTable(**columns),
                meta=meta,
                payloads=data["messages"].astype(np.uint8, copy=False),
                offsets=data["message_offsets"].astype(np.int64, copy=False),
                topics=data["message_topics"],
                recv_t=data["message_recv_t"].astype(np.float64, copy=False),
            )
        except KeyError:
            missing = [n for n in _arrays() if n not in data.files] or ["(unknown)"]
            more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
            raise RecordingError(
                f"{shown(path)}: not a stiction recording (it lacks the arrays "
                f"{', '.join(missing[:3])}{more})"
            ) from None
        except RecursionError:  # a meta JSON nested past the decoder's limit
            raise RecordingError(
                f"{shown(path)}: damaged recording (meta nested too deeply)"
            ) from None
        except (ValueError, TypeError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
            raise RecordingError(f"{path}: damaged recording ({exc})") from exc
    n = len(rec.topics)
    if rec.offsets.shape != (n + 1,) or (n and int(rec.offsets[-1]) != rec.payloads.shape[0]):
        raise RecordingError(f"{path}: message index does not match the message buffer")
    if n and (np.any(np.diff(rec.offsets) < 0) or int(rec.offsets[0]) != 0):
        raise RecordingError(f"{path}: message offsets are not increasing")
    return rec


def check_messages(rec: Recording, where: str) -> None:
    """Decode every message once, so replay never publishes something broken."""
    for i, (topic, payload) in enumerate(rec.messages()):
        try:
            parse_message(topic, payload)
        except ProtocolError as exc:
            raise RecordingError(f"{where}: message {i}: {exc}") from exc
