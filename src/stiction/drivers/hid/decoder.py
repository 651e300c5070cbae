"""Compiled report decoders: bit offsets worked out once per report ID.

A tablet sends a report every 4 to 8 ms and a replay may hold millions, so a
report is never parsed field by field. For one report at a time the layout
becomes one small generated function (the report read as one integer, then a
shift and a mask per value); for a whole recording the reports become a
(n, length) byte array and every group of values that fits in one 64-bit
window is cut out with two broadcast numpy operations.

Values are the fields' logical values, sign-extended where the logical
minimum is negative (the kernel's rule). Constant (padding) fields are left
out; an array field contributes `count` values (the usage indices).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from stiction.drivers.hid.descriptor import Field, Report


@dataclass(frozen=True, slots=True)
class Element:
    """One value in a report: which field it belongs to and where its bits are."""

    field_index: int
    usage: int
    bit_offset: int
    bit_size: int
    signed: bool


def _elements(report: Report) -> list[Element]:
    out: list[Element] = []
    for i, f in enumerate(report.fields):
        if f.constant:
            continue
        for k in range(f.count):
            usage = f.usage
            out.append(Element(i, usage, f.bit_offset + k * f.bit_size, f.bit_size, f.signed))
    return out


_STRUCT_CODES = {
    (8, False): "B",
    (8, True): "b",
    (16, False): "H",
    (16, True): "h",
    (32, False): "I",
    (32, True): "i",
    (64, False): "Q",
    (64, True): "q",
}


def _byte_table(elements: list[Element]) -> tuple[tuple[int, ...], ...]:
    """For each possible byte value, the values of `elements` (all inside that byte)."""
    table = []
    for b in range(256):
        vals = []
        for e in elements:
            x = (b >> (e.bit_offset % 8)) & ((1 << e.bit_size) - 1)
            if e.signed and x >> (e.bit_size - 1):
                x -= 1 << e.bit_size
            vals.append(x)
        table.append(tuple(vals))
    return tuple(table)


FLAT_PARTS = 64
"""Above this many runs the generated decoder builds its tuple in one flat display."""


def _plan(
    elements: list[Element], namespace: dict[str, object]
) -> tuple[list[tuple[str, int, str | None]], bool]:
    """Cut the elements, in order, into runs that one cheap C-level step decodes.

    Bit flags sharing a byte become one lookup in a 256-entry table of
    tuples, byte-aligned 8/16/32/64-bit values in a row become one
    `struct.unpack_from`, and anything else is a shift and mask of the
    report read once as the integer ``v``. Returns one expression per run
    (each a tuple of that run's values, reading the report ``d``; tables and
    unpackers go into `namespace`), with how many values it yields and, for a
    run of one value, its expression without the tuple; and whether ``v`` is
    needed. The expressions hold only numbers computed here, never input bytes.
    """
    parts: list[tuple[str, int, str | None]] = []
    need_int = False
    i = 0
    n = len(elements)
    while i < n:
        e = elements[i]
        start, shift = divmod(e.bit_offset, 8)
        if e.bit_size == 0:
            parts.append(("(0,)", 1, "0"))  # a zero-bit field (Report Size 0) reads as 0
            i += 1
            continue
        if shift + e.bit_size <= 8 and e.bit_size < 8:
            j = i + 1
            while (
                j < n
                and elements[j].bit_offset // 8 == start
                and elements[j].bit_offset % 8 + elements[j].bit_size <= 8
            ):
                j += 1
            name = f"T{len(namespace)}"
            namespace[name] = _byte_table(elements[i:j])
            parts.append((f"{name}[d[{start}]]", j - i, None))
            i = j
            continue
        if shift == 0 and (e.bit_size, e.signed) in _STRUCT_CODES:
            fmt = "<"
            end = start
            j = i
            while j < n:
                f = elements[j]
                code = _STRUCT_CODES.get((f.bit_size, f.signed))
                fstart, fshift = divmod(f.bit_offset, 8)
                if code is None or fshift or fstart < end:
                    break
                fmt += "x" * (fstart - end) + code
                end = fstart + f.bit_size // 8
                j += 1
            name = f"S{len(namespace)}"
            namespace[name] = struct.Struct(fmt).unpack_from
            parts.append((f"{name}(d, {start})", j - i, None))
            i = j
            continue
        need_int = True
        # hex literals: a padding field merged from thousands of elements can
        # be thousands of bits wide, beyond Python's limit for decimal ints
        mask = (1 << e.bit_size) - 1
        expr = f"((v >> {e.bit_offset}) & {mask:#x})" if e.bit_offset else f"(v & {mask:#x})"
        if e.signed:
            sign = 1 << (e.bit_size - 1)
            expr = f"(({expr} ^ {sign:#x}) - {sign:#x})"
        parts.append((f"({expr},)", 1, expr))
        i += 1
    return parts, need_int


def decode_statements(
    elements: list[Element], names: list[str], namespace: dict[str, object]
) -> list[str]:
    """Statements (unindented) that set variable names[i] to elements[i]'s value from ``d``.

    What `_compile_one`'s function computes, written into a caller's
    generated function (report_code.py) so that no tuple of all values is
    built and unpacked there.
    """
    parts, need_int = _plan(elements, namespace)
    lines = ["v = int.from_bytes(d, 'little')"] if need_int else []
    k = 0
    for expr, count, scalar in parts:
        if scalar is not None:
            lines.append(f"{names[k]} = {scalar}")
        else:
            lines.append(f"({', '.join(names[k : k + count])},) = {expr}")
        k += count
    return lines


def _compile_one(elements: list[Element]) -> Callable[[bytes], tuple[int, ...]]:
    """Generate ``decode(data) -> tuple`` for this layout (the runs of `_plan`, joined)."""
    namespace: dict[str, object] = {}
    runs, need_int = _plan(elements, namespace)
    parts = [expr for expr, _, _ in runs]
    lines = ["def decode(d):"]
    if need_int:
        lines.append("    v = int.from_bytes(d, 'little')")
    if len(parts) > FLAT_PARTS:
        # `a + b + ...` nests one level per term and a descriptor's thousands
        # of fields overflow the compiler's recursion; a starred display is flat.
        lines.append(f"    return ({', '.join('*' + p for p in parts)},)")
    else:
        lines.append(f"    return {' + '.join(parts) if parts else '()'}")
    exec(compile("\n".join(lines), "<hid report decoder>", "exec"), namespace)
    fn = namespace["decode"]
    assert callable(fn)
    return fn  # type: ignore[no-any-return]


@dataclass(frozen=True, slots=True)
class _Window:
    """Elements that fit in the 64-bit little-endian word starting at `byte`."""

    byte: int
    columns: npt.NDArray[np.intp]
    shifts: npt.NDArray[np.uint64]
    masks: npt.NDArray[np.uint64]
    contiguous: tuple[int, int] | None  # columns as a slice, when they are consecutive


class ReportDecoder:
    """Decoder for one input report ID; `elements` name the decoded values in order."""

    def __init__(self, report: Report) -> None:
        self.report = report
        self.report_id = report.report_id
        self.byte_size = report.byte_size
        self.elements = _elements(report)
        self.decode: Callable[[bytes], tuple[int, ...]] = _compile_one(self.elements)
        self._aligned, self._in_byte, rest = self._plan_simple()
        self._windows, self._wide = self._plan_windows(rest)
        self._dtypes: dict[int, np.dtype[np.void]] = {}
        # Sign extension is needed only where values come out of a 64-bit window.
        in_windows = {int(c) for w in self._windows for c in w.columns}
        self._window_signed = [
            (i, 1 << (e.bit_size - 1))
            for i, e in enumerate(self.elements)
            if e.signed and i in in_windows
        ]

    def _plan_simple(
        self,
    ) -> tuple[list[tuple[int, str, int]], list[tuple[int, int, int, int]], list[int]]:
        """Split elements into byte-aligned integers, values inside one byte, and the rest.

        Aligned 8/16/32/64-bit values are read through a structured dtype
        view of the rows (no arithmetic at all); values inside one byte
        with uint8 shifts; only the rest needs 64-bit windows.
        """
        aligned: list[tuple[int, str, int]] = []
        in_byte: list[tuple[int, int, int, int]] = []
        rest: list[int] = []
        for i, e in enumerate(self.elements):
            start, shift = divmod(e.bit_offset, 8)
            code = _STRUCT_CODES.get((e.bit_size, e.signed))
            if e.bit_size == 0:
                continue  # reads as 0: the output column is zeroed
            if shift == 0 and code is not None:
                aligned.append((i, "<" + code, start))
            elif shift + e.bit_size <= 8 and not e.signed:
                in_byte.append((i, start, shift, (1 << e.bit_size) - 1))
            else:
                rest.append(i)
        return aligned, in_byte, rest

    def _dtype(self, stride: int) -> np.dtype[np.void]:
        dt = self._dtypes.get(stride)
        if dt is None:
            dt = np.dtype(
                {
                    "names": [f"e{i}" for i, _, _ in self._aligned],
                    "formats": [code for _, code, _ in self._aligned],
                    "offsets": [off for _, _, off in self._aligned],
                    "itemsize": stride,
                }
            )
            self._dtypes[stride] = dt
        return dt

    def _plan_windows(self, rest: list[int]) -> tuple[list[_Window], list[int]]:
        windows: list[_Window] = []
        wide: list[int] = []
        order = sorted(rest, key=lambda i: self.elements[i].bit_offset)
        current: list[int] = []
        base = 0

        def flush() -> None:
            if current:
                run = (current[0], current[-1] + 1)
                consecutive = current == list(range(*run))
                windows.append(
                    _Window(
                        base,
                        np.array(current, dtype=np.intp),
                        np.array(
                            [self.elements[i].bit_offset - 8 * base for i in current],
                            dtype=np.uint64,
                        ),
                        np.array(
                            [(1 << self.elements[i].bit_size) - 1 for i in current],
                            dtype=np.uint64,
                        ),
                        run if consecutive else None,
                    )
                )

        for i in order:
            e = self.elements[i]
            if e.bit_size > 57:
                wide.append(i)  # cannot sit in one 64-bit window at any bit shift
                continue
            if current and e.bit_offset + e.bit_size <= 8 * base + 64:
                current.append(i)
                continue
            flush()
            base = e.bit_offset // 8
            current = [i]
        flush()
        return windows, wide

    def values(self, data: bytes) -> dict[int, list[int]]:
        """Values keyed by usage (several occurrences of a usage are listed in order)."""
        out: dict[int, list[int]] = {}
        for e, v in zip(self.elements, self.decode(data), strict=True):
            out.setdefault(e.usage, []).append(v)
        return out

    @property
    def padded_length(self) -> int:
        """Row length that lets decode_batch read every 64-bit window without copying."""
        last = max((w.byte + 8 for w in self._windows), default=0)
        return max(self.byte_size, last)

    def reports_array(self, reports: list[bytes]) -> npt.NDArray[np.uint8]:
        """Rows of `reports` (each at least byte_size long) in an array decode_batch reads as is."""
        width = self.padded_length
        n = len(reports)
        lengths = {len(r) for r in reports}
        if len(lengths) == 1:
            (length,) = lengths
            raw = np.frombuffer(b"".join(reports), dtype=np.uint8).reshape(n, length)
            if length >= width:
                return raw
            out = np.zeros((n, width), dtype=np.uint8)
            out[:, :length] = raw
            return out
        buf = bytearray(width * n)
        for i, r in enumerate(reports):
            chunk = r[:width]
            buf[i * width : i * width + len(chunk)] = chunk
        return np.frombuffer(bytes(buf), dtype=np.uint8).reshape(n, width)

    def decode_batch(self, reports: npt.NDArray[np.uint8]) -> npt.NDArray[np.int64]:
        """Decode a (n, length) byte array of reports of this ID into an (n, elements) array.

        Rows shorter than the report must have been filtered out by the
        caller; extra bytes per row are ignored. An array at least
        `padded_length` wide and C-contiguous (what `reports_array` builds)
        is read in place; anything else is copied into one first. Elements
        wider than 57 bits (vendor blobs, never pen coordinates) are decoded
        per row.
        """
        n, length = reports.shape
        if length < self.byte_size:
            raise ValueError(
                f"rows of {length} bytes, report {self.report_id} needs {self.byte_size}"
            )
        need = self.padded_length
        if length >= need and reports.flags.c_contiguous and reports.dtype == np.uint8:
            buf, stride = reports, length
        else:
            stride = max(length, need)
            buf = np.zeros((n, stride), dtype=np.uint8)
            buf[:, :length] = reports
        out = np.zeros((n, len(self.elements)), dtype=np.int64, order="F")
        if self._aligned:
            rows = buf.view(np.uint8).reshape(n * stride).view(self._dtype(stride))
            for i, _, _ in self._aligned:
                out[:, i] = rows[f"e{i}"]
        for i, byte, shift, mask in self._in_byte:
            column = buf[:, byte]
            out[:, i] = (column >> shift) & mask if shift else column & mask
        for w in self._windows:
            words = np.ndarray((n,), dtype="<u8", buffer=buf.data, offset=w.byte, strides=(stride,))
            vals = ((words[:, None] >> w.shifts) & w.masks).view(np.int64)
            if w.contiguous is not None:
                out[:, w.contiguous[0] : w.contiguous[1]] = vals
            else:
                out[:, w.columns] = vals
        for col, sign in self._window_signed:
            out[:, col] = (out[:, col] ^ sign) - sign
        for i in self._wide:
            e = self.elements[i]
            mask = (1 << e.bit_size) - 1
            for r in range(n):
                v = (int.from_bytes(bytes(reports[r]), "little") >> e.bit_offset) & mask
                if e.signed and v >> (e.bit_size - 1):
                    v -= 1 << e.bit_size
                out[r, i] = max(min(v, 2**63 - 1), -(2**63))
        return out


def field_values(field: Field, data: bytes) -> list[int]:
    """The values of one field, read the slow obvious way (the reference for tests)."""
    v = int.from_bytes(data, "little")
    out = []
    for k in range(field.count):
        x = (v >> (field.bit_offset + k * field.bit_size)) & ((1 << field.bit_size) - 1)
        if field.signed and x >> (field.bit_size - 1):
            x -= 1 << field.bit_size
        out.append(x)
    return out
