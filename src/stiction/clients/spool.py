"""The recorder's spool: what `stiction record` received, on disk as it arrives.

Why: a recorder that keeps the whole session in memory and writes the .npz at
the end grows without bound (about 100 MB an hour of frames, several times
that as Python objects) and loses everything when it is killed (SIGKILL, the
OOM killer, a power cut) before the end. So the recorder keeps one chunk of
messages in memory and appends it to a spool next to the output,
``<out>.partial`` (``trial.npz`` -> ``trial.npz.partial``), every ``CHUNK``
messages or every ``FLUSH_EVERY`` seconds, whichever comes first. A clean stop
assembles the .npz from the spool and deletes the spool; a killed recorder
leaves it, and ``recover()`` (``stiction record --recover
trial.npz.partial``, or simply the next ``stiction record --out trial.npz``)
turns it into the same .npz format, minus the chunk that was not yet flushed.

The design, and why:

- **One append-only file of self-checking records**, not a directory of chunk
  files or one file per column. Each record is a fixed head (tag, header
  length, body length, CRC-32 of header and body), a JSON header, and a body.
  A flush is one append and one fdatasync, the file is one lock, and recovery
  needs no ordering between files: a record is whole (lengths and CRC match)
  or it is the torn tail of a write that was cut off, which is ignored, with
  anything after it.
- **Chunks hold columns, not only messages.** A chunk record's body is the
  chunk's ContactTable columns (``contact_frame`` already counted from the
  first frame of the session) and its raw messages, as raw numpy bytes; the
  header names each column's dtype and shape. The recorder parses every frame
  anyway, so the columns are computed while recording (a chunk at a time), and
  assembling a recording is copying bytes, not decoding every message again.
- **Everything the final metadata needs is in the spool.** The first record is
  the metadata asked of the daemon at start; each chunk carries its scene
  changes, the subscriber's counters and the time since the start. A killed
  session's recording lacks only the unflushed chunk (and says it was
  recovered, in ``meta["recovered"]``).
- **fdatasync after every record**, so what was flushed survives a power cut,
  not only a killed process. The recorder holds an ``flock`` on the spool
  while it writes; a recovery or a second recorder with the same output sees
  a live spool as busy, and the kernel drops the lock however the recorder
  dies. The spool is created under a temporary name and hard-linked into
  place, so no one ever sees it unlocked before its writer holds it.

Assembly streams: the .npz is written member by member with ``zipfile``
(ZIP_DEFLATED, as ``np.savez_compressed`` does, and ``force_zip64`` because a
member's size is not known when it starts). A first pass over the records
checks them and sums each column's rows (fixed-width strings take the widest
chunk's width); then each member gets its ``.npy`` header with the total
shape, and its rows chunk by chunk. Memory is one chunk of one column at a
time, plus the metadata (the scene changes among it), which is one JSON string
in the file and so is held whole.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import json
import logging
import math
import os
import struct
import tempfile
import zipfile
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, fields
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import numpy as np
import numpy.typing as npt

from stiction.clients import recording
from stiction.clients.columns import ContactTable
from stiction.clients.messages import Frame, Message, SceneMessage
from stiction.errors import RecordingError
from stiction.userfiles import open_regular, shown

log = logging.getLogger("stiction.clients.spool")

SUFFIX = ".partial"
CHUNK = 1000
"""Messages held in memory before they are flushed to the spool."""
FLUSH_EVERY = 1.0
"""Seconds after which pending messages are flushed however few they are."""

_MAGIC = b"STICTION-SPOOL\n\x01"  # format name, then the spool format version (1)
_HEAD = struct.Struct("<4sIQI")  # tag, header bytes, body bytes, CRC-32 of header + body
_TAG = b"SREC"
_NO_LIMIT = 1 << 62  # a spool is as long as the session was
_MAX_HEADER = 64 << 20
_BLOCK = 1 << 20

TABLE_COLUMNS = tuple(f.name for f in fields(ContactTable))
MESSAGE_COLUMNS = ("messages", "message_sizes", "message_topics", "message_recv_t")
SPOOL_COLUMNS = TABLE_COLUMNS + MESSAGE_COLUMNS
"""Columns of a chunk record's body, in order. ``message_sizes`` becomes the
recording's ``message_offsets`` (one longer, starting at 0)."""


def spool_path(out: str | Path) -> Path:
    """Where the recorder writing ``out`` spools: ``out`` + ``.partial``."""
    out = Path(out)
    return out.with_name(out.name + SUFFIX)


def default_output(spool: str | Path) -> Path:
    """The recording a spool was meant to become: its name without ``.partial``."""
    spool = Path(spool)
    name = spool.name.removesuffix(SUFFIX)
    return spool.with_name(name if name.endswith(".npz") else name + ".npz")


def recover_command(spool: Path) -> str:
    """What to run to turn a spool into a recording, for error messages."""
    return f"stiction record --recover {spool}"


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


@functools.cache
def _template() -> dict[str, npt.NDArray[Any]]:
    """Each column as an empty array: the dtype and trailing shape of a session
    without messages, which is what the in-memory writer produces then (read
    only: the dict is shared)."""
    empty: dict[str, npt.NDArray[Any]] = dict(ContactTable.from_frames([]).as_dict())
    empty["messages"] = np.zeros(0, dtype=np.uint8)
    empty["message_sizes"] = np.zeros(0, dtype=np.int64)
    empty["message_topics"] = np.asarray([], dtype=np.str_)
    empty["message_recv_t"] = np.zeros(0, dtype=np.float64)
    return empty


def _make_parent(path: Path) -> None:
    """Create the directory ``path`` goes in, if missing; a parent that is a file
    is left for open() to report (as "Not a directory", which says what is wrong)."""
    if not path.parent.exists():
        path.parent.mkdir(parents=True)


def _write_all(fd: int, data: bytes | memoryview) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


class SpoolWriter:
    """Appends one session's messages to its spool, a chunk at a time.

    ``add`` keeps a message in memory; ``flush`` writes the pending chunk as one
    record; ``finish`` flushes the last one, assembles the recording and
    deletes the spool; ``close`` lets go of the spool and keeps it (a failed
    session: what was flushed can be recovered).
    """

    def __init__(self, path: Path, fd: int, *, fsync: bool) -> None:
        self.path = path
        self._fd: int | None = fd
        self._fsync = fsync
        self._end = os.lseek(fd, 0, os.SEEK_END)
        self._topics: list[bytes] = []
        self._payloads: list[bytes] = []
        self._recv_t: list[float] = []
        self._frames: list[Frame] = []
        self._scenes: list[dict[str, Any]] = []
        self.frames = 0
        """Frames added (flushed or pending)."""
        self.contacts = 0
        self.scenes = 0
        self.flushed_frames = 0
        self.chunks = 0
        self.broken = False
        """A write failed: the spool keeps what was flushed before, nothing more."""

    @classmethod
    def create(cls, path: str | Path, *, fsync: bool = True) -> SpoolWriter:
        """A new spool at ``path``; RecordingError if one is there already."""
        path = Path(path)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.new")
        try:
            _make_parent(path)
            fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise RecordingError(f"{path}: cannot create the spool ({_why(exc)})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            _write_all(fd, _MAGIC)
            os.link(tmp, path)  # appears already locked, and never replaces another spool
        except FileExistsError:
            os.close(fd)
            raise RecordingError(
                f"{path} exists: another `stiction record` is writing the same file, "
                "or a killed one left it (it can be recovered)"
            ) from None
        except OSError as exc:
            os.close(fd)
            raise RecordingError(f"{path}: cannot create the spool ({_why(exc)})") from None
        finally:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        return cls(path, fd, fsync=fsync)

    @property
    def pending(self) -> int:
        """Messages in memory, not yet flushed."""
        return len(self._topics)

    def add(self, topic: bytes, payload: bytes, recv_t: float, msg: Message) -> None:
        """Hold one received message (``payload`` is what replay publishes)."""
        self._topics.append(topic)
        self._payloads.append(payload)
        self._recv_t.append(recv_t)
        if isinstance(msg, SceneMessage):
            self._scenes.append({"tick": msg.tick, "scene": msg.scene})
            self.scenes += 1
        else:
            self._frames.append(msg)
            self.frames += 1
            self.contacts += len(msg.contacts)

    def write_meta(self, meta: Mapping[str, Any]) -> None:
        """The metadata asked of the daemon at start: the spool's first record."""
        self._append({"kind": "meta", "meta": dict(meta), "pid": os.getpid()}, [])

    def flush(
        self, stats: Mapping[str, Any] | None, duration_s: float, *, final: bool = False
    ) -> None:
        """Write the pending chunk as one record (and fdatasync it)."""
        table = dict(ContactTable.from_frames(self._frames).as_dict())
        table["contact_frame"] = table["contact_frame"] + self.flushed_frames
        columns: dict[str, npt.NDArray[Any]] = {
            **table,
            "messages": np.frombuffer(b"".join(self._payloads), dtype=np.uint8),
            "message_sizes": np.fromiter(
                (len(p) for p in self._payloads), dtype=np.int64, count=len(self._payloads)
            ),
            "message_topics": np.asarray(
                [t.decode("utf-8", "replace") for t in self._topics], dtype=np.str_
            ),
            "message_recv_t": np.asarray(self._recv_t, dtype=np.float64),
        }
        arrays = [np.ascontiguousarray(columns[name]) for name in SPOOL_COLUMNS]
        header = {
            "kind": "chunk",
            "frames": len(self._frames),
            "messages": len(self._topics),
            "columns": [
                [name, np.lib.format.dtype_to_descr(a.dtype), list(a.shape)]
                for name, a in zip(SPOOL_COLUMNS, arrays, strict=True)
            ],
            "scenes": self._scenes,
            "stats": None if stats is None else dict(stats),
            "duration_s": duration_s,
            "final": final,
        }
        self._append(header, [a.reshape(-1).view(np.uint8).data for a in arrays])
        self.flushed_frames += len(self._frames)
        self.chunks += 1
        self._topics, self._payloads, self._recv_t = [], [], []
        self._frames, self._scenes = [], []

    def _append(self, header: dict[str, Any], body: list[memoryview]) -> None:
        if self._fd is None or self.broken:
            raise RecordingError(f"{self.path}: the spool is closed")
        head = json.dumps(header, separators=(",", ":"), default=str).encode("utf-8")
        crc = zlib.crc32(head)
        for part in body:
            crc = zlib.crc32(part, crc)
        size = sum(part.nbytes for part in body)
        try:
            _write_all(self._fd, _HEAD.pack(_TAG, len(head), size, crc) + head)
            for part in body:
                _write_all(self._fd, part)
            if self._fsync:
                os.fdatasync(self._fd)
        except OSError as exc:
            self.broken = True
            with contextlib.suppress(OSError):  # drop the torn record (it would be skipped anyway)
                os.ftruncate(self._fd, self._end)
            raise RecordingError(
                f"{self.path}: cannot write the recording spool ({_why(exc)}); "
                f"it keeps the {self.flushed_frames} frames flushed before; "
                f"make a recording of them with `{recover_command(self.path)}`"
            ) from None
        self._end += _HEAD.size + len(head) + size

    def finish(
        self, out: str | Path, stats: Mapping[str, Any] | None, duration_s: float
    ) -> Summary:
        """Flush the last chunk, write the recording ``out`` from the spool, delete
        the spool. If writing ``out`` fails, the spool is kept (RecordingError
        says so)."""
        self.flush(stats, duration_s, final=True)
        try:
            summary = assemble(self.path, out)
        except RecordingError as exc:
            self.close()
            raise RecordingError(
                f"{exc}; everything received is kept in {self.path}: "
                f"`{recover_command(self.path)}` makes the recording"
            ) from None
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        self.close()
        return summary

    def discard(self) -> None:
        """Delete the spool: for a session that failed before it received anything."""
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        self.close()

    def close(self) -> None:
        """Let go of the spool (and its lock) and keep it, as a killed recorder would."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


@dataclass(frozen=True)
class Column:
    """One column of one chunk record: where its bytes are and what they are."""

    name: str
    dtype: np.dtype[Any]
    shape: tuple[int, ...]
    offset: int
    """From the start of the file."""
    nbytes: int


@dataclass
class Summary:
    """What a spool holds, from a pass over its whole records."""

    path: Path
    meta: dict[str, Any] | None
    chunks: int = 0
    final: bool = False
    """The recorder flushed its last chunk: nothing was lost."""
    end: int = len(_MAGIC)
    """Offset after the last whole record."""
    size: int = 0
    """File size: bytes between ``end`` and ``size`` are a torn tail, ignored."""
    rows: dict[str, int] | None = None
    dtypes: dict[str, np.dtype[Any]] | None = None
    scenes: list[dict[str, Any]] | None = None
    stats: dict[str, Any] | None = None
    duration_s: float | None = None
    output: Path | None = None
    """The recording written from it, once assembled."""

    @property
    def frames(self) -> int:
        return self.rows["frame_tick"] if self.rows else 0

    @property
    def contacts(self) -> int:
        return self.rows["id"] if self.rows else 0

    @property
    def messages(self) -> int:
        return self.rows["message_topics"] if self.rows else 0

    @property
    def scene_count(self) -> int:
        return len(self.scenes or [])


def _records(
    fh: IO[bytes], path: Path, *, check: bool, end: int | None = None
) -> Iterator[tuple[dict[str, Any], int, int]]:
    """(header, body offset, body length) of each record, in order. With
    ``check``, stop at the first record that is cut off or fails its CRC."""
    fh.seek(0)
    if fh.read(len(_MAGIC)) != _MAGIC:
        raise RecordingError(f"{path}: not a stiction recording spool (no spool header)")
    pos = len(_MAGIC)
    while end is None or pos < end:
        fh.seek(pos)
        raw = fh.read(_HEAD.size)
        if len(raw) < _HEAD.size:
            return
        tag, head_len, body_len, crc = _HEAD.unpack(raw)
        if tag != _TAG or head_len > _MAX_HEADER:
            return
        head = fh.read(head_len)
        if len(head) < head_len:
            return
        body = pos + _HEAD.size + head_len
        if check:
            got, left = zlib.crc32(head), body_len
            while left:
                block = fh.read(min(left, _BLOCK))
                if not block:
                    return
                got, left = zlib.crc32(block, got), left - len(block)
            if got != crc:
                return
        try:
            header = json.loads(head)
        except (ValueError, RecursionError):  # damaged, or nested past the decoder's limit
            return
        if not isinstance(header, dict):
            return
        yield header, body, body_len
        pos = body + body_len


def _columns(header: dict[str, Any], body: int, body_len: int, path: Path) -> list[Column]:
    """The columns of a chunk record, checked against what a recording holds."""
    template = _template()
    out: list[Column] = []
    offset = body
    try:
        for name, descr, shape in header["columns"]:
            dtype = np.dtype(descr)
            shape = tuple(int(n) for n in shape)
            want = template[name]
            if (
                dtype.kind != want.dtype.kind
                or (dtype.kind != "U" and dtype != want.dtype)
                or shape[1:] != want.shape[1:]
                or min(shape, default=0) < 0
            ):
                raise ValueError(f"column {name} is {descr} {list(shape)}")
            nbytes = math.prod(shape) * dtype.itemsize
            out.append(Column(name, dtype, shape, offset, nbytes))
            offset += nbytes
        if [c.name for c in out] != list(SPOOL_COLUMNS) or offset != body + body_len:
            raise ValueError("the columns do not match the record")
    except (KeyError, TypeError, ValueError) as exc:
        raise RecordingError(f"{path}: damaged spool record at byte {body} ({exc})") from None
    return out


def scan(fh: IO[bytes], path: Path) -> Summary:
    """Check every record and sum up the spool (the first assembly pass)."""
    template = _template()
    rows = dict.fromkeys(SPOOL_COLUMNS, 0)
    dtypes = {name: template[name].dtype for name in SPOOL_COLUMNS}
    summary = Summary(path=path, meta=None, rows=rows, dtypes=dtypes, scenes=[])
    scenes: list[dict[str, Any]] = []
    for header, body, body_len in _records(fh, path, check=True):
        if header.get("kind") == "meta" and summary.meta is None:
            meta = header.get("meta")
            summary.meta = meta if isinstance(meta, dict) else {}
        elif header.get("kind") == "chunk":
            try:
                columns = _columns(header, body, body_len, path)
            except RecordingError as exc:  # whole but not understood: keep what came before
                log.warning("%s; the chunks before it are kept", exc)
                break
            for col in columns:
                rows[col.name] += col.shape[0]
                if col.dtype.itemsize > dtypes[col.name].itemsize:
                    dtypes[col.name] = col.dtype
            scenes.extend(s for s in header.get("scenes") or [] if isinstance(s, dict))
            stats = header.get("stats")
            summary.stats = stats if isinstance(stats, dict) else None
            duration = header.get("duration_s")
            summary.duration_s = float(duration) if isinstance(duration, int | float) else None
            summary.final = bool(header.get("final"))
            summary.chunks += 1
        summary.end = body + body_len
    summary.scenes = scenes
    summary.size = fh.seek(0, os.SEEK_END)
    return summary


def _pieces(fh: IO[bytes], summary: Summary, name: str) -> Iterator[npt.NDArray[Any]]:
    """Column ``name`` of every chunk in order, one chunk in memory at a time."""
    for header, body, body_len in _records(fh, summary.path, check=False, end=summary.end):
        if header.get("kind") != "chunk":
            continue
        col = next(c for c in _columns(header, body, body_len, summary.path) if c.name == name)
        fh.seek(col.offset)
        data = fh.read(col.nbytes)
        if len(data) != col.nbytes:
            raise RecordingError(f"{summary.path}: the spool shrank while it was read")
        yield np.frombuffer(data, dtype=col.dtype).reshape(col.shape)


def _member(
    zf: zipfile.ZipFile,
    name: str,
    dtype: np.dtype[Any],
    shape: tuple[int, ...],
    pieces: Iterator[npt.NDArray[Any]],
) -> None:
    """One .npy member streamed: the header with the total shape, then the rows."""
    with zf.open(name + ".npy", "w", force_zip64=True) as member:
        np.lib.format.write_array_header_1_0(
            member,
            {
                "descr": np.lib.format.dtype_to_descr(dtype),
                "fortran_order": False,
                "shape": shape,
            },
        )
        written = 0
        for piece in pieces:
            member.write(np.ascontiguousarray(piece, dtype=dtype).tobytes())
            written += piece.shape[0] if piece.ndim else 1
        if written != (shape[0] if shape else 1):
            raise RecordingError(f"{name}: wrote {written} rows of {shape}")  # a bug, not input


def _offsets(fh: IO[bytes], summary: Summary) -> Iterator[npt.NDArray[np.int64]]:
    start = 0
    yield np.zeros(1, dtype=np.int64)
    for sizes in _pieces(fh, summary, "message_sizes"):
        offsets = np.cumsum(sizes, dtype=np.int64) + start
        if offsets.shape[0]:
            start = int(offsets[-1])
        yield offsets


def final_meta(summary: Summary, *, recovered: bool) -> dict[str, Any]:
    """The recording's metadata, as the recorder of a clean stop would write it."""
    if summary.meta is None:
        meta: dict[str, Any] = {"spool_error": "the recorder stopped before it had the metadata"}
    else:
        meta = dict(summary.meta)
    scenes = summary.scenes or []
    if meta.get("scene") is None and scenes:
        meta["scene"] = scenes[0].get("scene")
    meta["scene_changes"] = scenes
    meta["subscriber_stats"] = summary.stats
    meta["duration_s"] = summary.duration_s if summary.duration_s is not None else 0.0
    if recovered:
        meta["recovered"] = {
            "spool": str(summary.path),
            "recovered_utc": datetime.now(UTC).isoformat(),
            "complete": summary.final,
            "chunks": summary.chunks,
            "ignored_bytes": summary.size - summary.end,
        }
    return meta


@contextlib.contextmanager
def _atomic(path: Path) -> Iterator[IO[bytes]]:
    """A temporary file that becomes ``path`` (synced) when the block succeeds."""
    try:
        _make_parent(path)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise RecordingError(f"{path}: cannot write the recording ({_why(exc)})") from None
    try:
        with os.fdopen(fd, "w+b") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        dfd = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise RecordingError(f"{path}: cannot write the recording ({_why(exc)})") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _assemble(fh: IO[bytes], summary: Summary, out: Path, *, recovered: bool) -> None:
    assert summary.rows is not None and summary.dtypes is not None
    rows, dtypes, template = summary.rows, summary.dtypes, _template()
    meta = recording.meta_json(
        final_meta(summary, recovered=recovered),
        frames=summary.frames,
        messages=summary.messages,
    )

    def shape(name: str) -> tuple[int, ...]:
        return (rows[name], *template[name].shape[1:])

    with (
        _atomic(out) as dst,
        zipfile.ZipFile(dst, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf,
    ):
        for name in (*TABLE_COLUMNS, "messages"):
            _member(zf, name, dtypes[name], shape(name), _pieces(fh, summary, name))
        n = summary.messages
        _member(zf, "message_offsets", np.dtype(np.int64), (n + 1,), _offsets(fh, summary))
        for name in ("message_topics", "message_recv_t"):
            _member(zf, name, dtypes[name], shape(name), _pieces(fh, summary, name))
        meta_array = np.asarray(meta)
        _member(zf, "meta", meta_array.dtype, (), iter([meta_array]))
    summary.output = out


def _open(path: Path) -> IO[bytes]:
    """The spool, opened only if it is a regular file: a FIFO given to --recover must
    not block the recorder (the spool's size is bounded by the disk, not here)."""
    if not path.exists():
        raise RecordingError(f"{shown(path)}: no such spool")
    return open_regular(path, _NO_LIMIT, RecordingError, "spool")


def assemble(spool: str | Path, out: str | Path, *, recovered: bool = False) -> Summary:
    """Write the recording ``out`` from ``spool`` (which stays); see the module doc."""
    spool, out = Path(spool), Path(out)
    with _open(spool) as fh:
        try:
            summary = scan(fh, spool)
            _assemble(fh, summary, out, recovered=recovered)
        except OSError as exc:  # reading the spool (writing ``out`` says so itself)
            raise RecordingError(f"{spool}: cannot read the spool ({_why(exc)})") from None
    return summary


def recover(
    spool: str | Path,
    out: str | Path | None = None,
    *,
    overwrite: bool = False,
    keep_empty: bool = True,
) -> Summary:
    """Turn the spool of a recorder that did not finish into a recording.

    ``out`` defaults to the name the session was recording to. An existing file
    is not replaced unless ``overwrite``; a spool still being written (its
    recorder is alive) is refused. With ``keep_empty=False`` a spool without a
    single message is deleted without writing a recording (``output`` is then
    None). The spool is deleted once the recording is written.
    """
    spool = Path(spool)
    target = default_output(spool) if out is None else Path(out)
    if target.suffix != ".npz":
        raise RecordingError(f"{target}: recordings are numpy .npz files; name it *.npz")
    with _open(spool) as fh:
        if target.exists() and not overwrite:
            raise RecordingError(f"{target} exists; recovering {spool} never replaces a recording")
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RecordingError(
                f"{spool}: a running `stiction record` is still writing it; "
                "stop it (Ctrl-C or SIGTERM) and it writes its recording itself"
            ) from None
        try:
            summary = scan(fh, spool)
            if summary.messages or keep_empty:
                _assemble(fh, summary, target, recovered=True)
        except OSError as exc:
            raise RecordingError(f"{spool}: cannot read the spool ({_why(exc)})") from None
        if summary.size > summary.end:
            log.warning(
                "%s: ignored %d bytes after the last whole chunk (a write cut off)",
                spool,
                summary.size - summary.end,
            )
        try:
            spool.unlink()
        except OSError as exc:
            log.warning("%s: recovered, but cannot delete it (%s)", spool, _why(exc))
    return summary
