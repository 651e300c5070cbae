"""Device coverage: the surface stiction finds for real descriptors, against libinput's size.

    stiction bench devices [--json] [--data DIR] [--recordings DIR] [--limit N]

Every descriptor of shared/data/coverage (each captured on a real machine,
with the kernel driver that was bound and the size libinput reported there)
goes through `describe_device`, the entry point `stiction hid describe` and
the daemon use, so the device catalogue counts as soon as it ships. Beside
it, the descriptor-only result: what the report descriptor alone gives
(`parse_descriptor` + `ReportStream` without a table entry), the naive
alternative. A size matches when each side is within 2% or 1.5 mm of
libinput's. libinput's own figure is not taken as truth: where it is the
kernel's rounding of the descriptor's size (see `_kernel_res`), not what the
kernel derives from this descriptor at all, or physically impossible, the
device is listed as "libinput wrong" with the reason, and not fitted to.

Every tablet recording of shared/data/hid is then replayed through the
daemon's decoding path (`open_replay`): it must give contacts, and its
surface must match an independent size where one exists (a coverage
capture or an OpenTabletDriver configuration of the same product).

Writes devices.{json,txt} in the results folder (--save: bench/results/).
"""

from __future__ import annotations

import argparse
import json
import os
import re
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from stiction.bench._support import results_dir, shared_data

if TYPE_CHECKING:
    from stiction.drivers.hid.descriptor import ReportDescriptor
    from stiction.drivers.hid.recording import Recording

TOL_REL, TOL_MM = 0.02, 1.5
TARGET_SURFACE, TARGET_MATCH = 0.98, 0.97
LIBINPUT_KIND = {"pen": "tablet", "touchscreen": "touchscreen", "touchpad": "touchpad"}
# Smaller than any pen tablet or screen: a dial or a wheel that libinput lists
# as a touch device (uclogic's frame dial is 10 x 10 mm), not a surface.
NOT_A_SURFACE_MM = 25.0

MAX_CLAMPED = 0.01  # of a recording's samples
OK_VERDICTS = ("match", "vendor-init", "not a surface", "no libinput size")


def sizes_match(ours_mm: tuple[float, float], theirs_mm: tuple[float, float]) -> bool:
    """Within 2% or 1.5 mm on each side (the issue's tolerance)."""
    return all(
        abs(a - b) <= max(TOL_REL * b, TOL_MM) for a, b in zip(ours_mm, theirs_mm, strict=True)
    )


@dataclass
class Row:
    """One capture: stiction's answer, the descriptor alone's, libinput's, and the verdict."""

    slug: str
    vid_pid: str
    driver: str | None
    kind: str | None
    surface_mm: tuple[float, float] | None
    size_from: str | None
    catalogue: str | None
    problem: str | None
    descriptor_only_mm: tuple[float, float] | None
    descriptor_only_problem: str | None
    libinput_mm: tuple[float, float] | None
    libinput_kind: str | None
    verdict: str = ""
    reason: str = ""


@contextmanager
def _no_user_table() -> Iterator[None]:
    """Measure the shipped catalogue, not this machine's own device table."""
    from stiction.drivers.hid.devices import USER_TABLE_ENV

    old = os.environ.get(USER_TABLE_ENV)
    os.environ[USER_TABLE_ENV] = os.devnull + ".stiction-bench-none"
    try:
        yield
    finally:
        if old is None:
            os.environ.pop(USER_TABLE_ENV, None)
        else:
            os.environ[USER_TABLE_ENV] = old


def _mm(size_m: tuple[float, float] | None) -> tuple[float, float] | None:
    return None if size_m is None else (size_m[0] * 1000.0, size_m[1] * 1000.0)


@lru_cache(maxsize=512)
def _parsed(raw: bytes) -> ReportDescriptor:
    """One parse per descriptor for the benchmark's own readings (stiction's are its own)."""
    from stiction.drivers.hid.descriptor import parse_descriptor

    return parse_descriptor(raw)


@lru_cache(maxsize=8)
def _oracles(coverage: Path) -> tuple[tuple[str, dict[str, Any]], ...]:
    """(slug, oracle) of a coverage folder, read once for all recordings."""
    return tuple((slug, o) for slug, o, _ in _captures(coverage, None))


def descriptor_only(raw: bytes, name: str) -> tuple[tuple[float, float] | None, str | None]:
    """What the descriptor alone gives: a surface in mm, or why not (no table entry)."""
    from stiction.drivers.hid.stream import ReportStream
    from stiction.errors import StictionError

    try:
        stream = ReportStream(_parsed(raw), name or "device")
    except StictionError as exc:
        return None, str(exc).split(": ", 1)[-1]
    return _mm(stream.surface_size), None


def _contact_axes(raw: bytes, finger: bool) -> list[tuple[Any, Any]]:
    """(X field, Y field) of every contact of the wanted kind in the device's own descriptor."""
    from stiction.drivers.hid.pen import build_mappings
    from stiction.errors import StictionError

    try:
        desc = _parsed(raw)
        mappings = build_mappings(desc, "device", size_m=(1.0, 1.0))
    except StictionError:
        return []
    axes = []
    for m in mappings.values():
        fields = m.decoder.report.fields
        for c in m.contacts:
            if c.finger == finger:
                fx = fields[m.decoder.elements[c.x.element].field_index]
                fy = fields[m.decoder.elements[c.y.element].field_index]
                axes.append((fx, fy))
    return axes


def _readings(
    raw: bytes, kind: str | None
) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """(the descriptor's size as written, the kernel's rounded size) in mm, per contact."""
    from stiction.bench._kernel_res import kernel_extent_mm
    from stiction.drivers.hid.units import extent_m

    out = []
    for fx, fy in _contact_axes(raw, finger=kind != "pen"):
        kw, kh = kernel_extent_mm(fx), kernel_extent_mm(fy)
        ew, eh = extent_m(fx), extent_m(fy)
        if kw is not None and kh is not None and ew is not None and eh is not None:
            out.append(((ew * 1000.0, eh * 1000.0), (kw, kh)))
    return out


def _other_kind(sized: list[dict[str, Any]], raw: bytes) -> tuple[dict[str, Any], str] | None:
    """(libinput device, verdict) for a node libinput saw only as another kind.

    A pen-and-touch node whose capture lists only the touch screen (or both
    as touch screens) is checked on what libinput did see: stiction's finger
    contacts against libinput's touch screen, as read ("match") or as the
    kernel rounds them ("libinput wrong").
    """
    from stiction.bench._kernel_res import kernel_extent_mm
    from stiction.drivers.hid.units import extent_m

    for d in sized:
        kind = d.get("kind")
        if kind not in ("tablet", "touchscreen", "touchpad"):
            continue
        lib = (float(d["size_mm"][0]), float(d["size_mm"][1]))
        for fx, fy in _contact_axes(raw, finger=kind != "tablet"):
            w, h = extent_m(fx), extent_m(fy)
            if w and h and sizes_match((w * 1000.0, h * 1000.0), lib):
                return d, "match"
            kw, kh = kernel_extent_mm(fx), kernel_extent_mm(fy)
            if kw and kh and sizes_match((kw, kh), lib):
                return d, "libinput wrong"
    return None


def _libinput_wrong(row: Row, raw: bytes) -> str | None:
    """Why libinput's size for this node cannot be the surface, or None if it may be."""
    lib, ours = row.libinput_mm, row.surface_mm
    if lib is None or ours is None:
        return None
    if min(lib) < NOT_A_SURFACE_MM and min(ours) >= NOT_A_SURFACE_MM:
        return f"{lib[0]:g} x {lib[1]:g} mm is no tablet or screen"
    readings = _readings(raw, row.kind)
    for written, kernel in readings:
        if sizes_match(kernel, lib) and sizes_match(ours, written):
            return (
                "the kernel rounds the resolution to whole units per mm: "
                f"{kernel[0]:.1f} x {kernel[1]:.1f} mm from a descriptor that says "
                f"{written[0]:.1f} x {written[1]:.1f} mm"
            )
    for written, kernel in readings:
        if sizes_match(kernel, lib) and any(
            sizes_match(ours, w) for w, _ in _readings(raw, "touchscreen")
        ):
            return (
                f"the pen report repeats the touch report's numbers in another unit: read as "
                f"written it spans {written[0]:.1f} x {written[1]:.1f} mm of a "
                f"{ours[0]:.1f} x {ours[1]:.1f} mm touch screen (see pen._one_panel)"
            )
    return None


def _unexplained(row: Row, raw: bytes) -> str:
    """Why a size differs from libinput's when neither side can be shown wrong."""
    lib = row.libinput_mm
    readings = _readings(raw, row.kind)
    if lib is not None and readings and not any(sizes_match(k, lib) for _, k in readings):
        k = readings[0][1]
        return (
            f"libinput's {lib[0]:g} x {lib[1]:g} mm is not what the kernel derives from this "
            f"descriptor ({k[0]:.1f} x {k[1]:.1f} mm): the capture's descriptor and libinput "
            "disagree; neither is fitted"
        )
    return "stiction's size differs from libinput's" if lib else "libinput has no size"


def classify(row: Row, oracle: dict[str, Any], raw: bytes) -> None:
    """Set the row's verdict and reason."""
    sized = [d for d in oracle["libinput"] if d.get("size_mm")]
    want = LIBINPUT_KIND.get(row.kind or "")
    same = [d for d in sized if d.get("kind") == want]
    pick = (same or sized or [None])[0]
    if pick is not None:
        row.libinput_mm = (float(pick["size_mm"][0]), float(pick["size_mm"][1]))
        row.libinput_kind = pick.get("kind")
    if row.problem and row.problem.startswith("refused: "):
        row.verdict, row.reason = "miss", row.problem
        return
    if row.surface_mm is not None and not sized:
        row.verdict = "no libinput size"
        row.reason = "libinput printed no size for this node: nothing to compare"
        return
    if row.surface_mm is not None:
        candidates = same or sized
        hit = next(
            (d for d in candidates if sizes_match(row.surface_mm, tuple(d["size_mm"]))), None
        )
        if hit is None and not same and (other := _other_kind(sized, raw)) is not None:
            d, verdict = other
            row.libinput_mm = (float(d["size_mm"][0]), float(d["size_mm"][1]))
            row.libinput_kind, row.verdict = d.get("kind"), verdict
            row.reason = f"libinput lists this node as {d.get('kind')} only; " + (
                "stiction's contacts of that kind match it"
                if verdict == "match"
                else "it is the kernel's rounding of stiction's contacts of that kind"
            )
            return
        if hit is not None:
            row.libinput_mm = (float(hit["size_mm"][0]), float(hit["size_mm"][1]))
            row.libinput_kind = hit.get("kind")
            row.verdict = "match"
            if not same:
                row.reason = f"libinput lists this node as {hit.get('kind')} only"
            return
        why = _libinput_wrong(row, raw)
        if why is not None:
            row.verdict, row.reason = "libinput wrong", why
            return
        row.verdict, row.reason = "miss", _unexplained(row, raw)
        return
    if row.size_from == "vendor-init":
        if want is not None and not same and sized:
            row.verdict = "miss"
            row.reason = (
                f"libinput sees only a {sized[0].get('kind')} on this node, which has a size "
                "in its descriptor, but its pen needs the vendor's initialisation, so the "
                "whole node waits for it"
            )
        else:
            row.verdict = "vendor-init"
            row.reason = "the tablet gives its size when opened (hid-uclogic does the same)"
        return
    if row.kind is None and not sized:
        row.verdict = "not a surface"
        row.reason = "no contact report, and libinput has no size for this node either"
        return
    if row.kind is None and sized and max(max(d["size_mm"]) for d in sized) < NOT_A_SURFACE_MM:
        row.verdict = "not a surface"
        row.reason = (
            f"libinput's {sized[0]['size_mm'][0]} x {sized[0]['size_mm'][1]} mm "
            f"{sized[0].get('kind')} is a dial or wheel, not a contact surface"
        )
        return
    row.verdict = "needs catalogue"
    driver = row.driver or "unknown"
    no_contacts = row.kind is None or "no pen, touch screen or touchpad report" in (
        row.problem or ""
    )
    if no_contacts and driver == "wacom":
        row.reason = (
            "the pen sits in Wacom's own report format; the kernel's wacom driver knows "
            "its layout and size from its device table"
        )
    elif no_contacts:
        row.reason = (
            "no digitizer report: the pen sits in a vendor or mouse collection, which only "
            f"device knowledge can name (the kernel bound {driver})"
        )
    elif row.problem and "physical size" in row.problem:
        unit = row.problem.split("(unit ", 1)[-1].split(",", 1)[0]
        row.reason = (
            f"its descriptor gives no length for X/Y (unit {unit}); the size is the "
            f"vendor's (libinput's came through {driver})"
        )
    else:
        row.reason = row.problem or "no size in its descriptor"
    if row.libinput_mm is not None and not no_contacts and not _readings(raw, row.kind):
        w, h = row.libinput_mm
        row.reason += (
            f"; libinput's {w:g} x {h:g} mm is not from this descriptor (the kernel derives "
            "no resolution from it), so it is no check of a size read from it"
        )


def _captures(data: Path, limit: int | None) -> Iterator[tuple[str, dict[str, Any], Recording]]:
    """(slug, oracle, descriptor) of every capture: <slug>.json beside <slug>.hid, or,
    in a folder that holds only the corpus, the lines of corpus.jsonl (descriptor_hex)."""
    from stiction.drivers.hid.recording import Recording, load_recording

    pairs = [p for p in sorted(data.glob("*.json")) if p.with_suffix(".hid").is_file()]
    if pairs or not (data / "corpus.jsonl").is_file():
        for path in pairs[:limit]:
            oracle = json.loads(path.read_text())
            if "libinput" in oracle:
                yield path.stem, oracle, load_recording(path.with_suffix(".hid"))
        return
    lines = (data / "corpus.jsonl").read_text().splitlines()
    for line in [ln for ln in lines if ln.strip()][:limit]:
        o = json.loads(line)
        raw = bytes.fromhex(o["descriptor_hex"])
        rec = Recording(o.get("product", ""), int(o["bus"], 16), int(o["vid"], 16),
                        int(o["pid"], 16), raw)  # fmt: skip
        yield o["slug"], o, rec


def coverage_rows(data: Path, limit: int | None = None) -> list[Row]:
    """One judged row per capture of the coverage folder."""
    from stiction.drivers.hid.facts import DeviceFacts, describe_device
    from stiction.errors import StictionError

    rows = []
    for slug, oracle, rec in _captures(data, limit):
        try:
            facts = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
        except StictionError as exc:  # a descriptor stiction refuses outright
            facts = DeviceFacts(None, None, None, None, "hidraw", f"refused: {exc}")
        only, only_problem = descriptor_only(rec.descriptor, rec.name)
        row = Row(
            slug=slug,
            vid_pid=f"{rec.vid:04x}:{rec.pid:04x}",
            driver=oracle.get("kernel_driver"),
            kind=facts.kind,
            surface_mm=_mm(facts.surface_m),
            size_from=facts.size_from,
            catalogue=facts.catalogue,
            problem=facts.problem,
            descriptor_only_mm=only,
            descriptor_only_problem=only_problem,
            libinput_mm=None,
            libinput_kind=None,
        )
        classify(row, oracle, rec.descriptor)
        rows.append(row)
    return rows


def _rates(rows: list[Row], only: bool = False) -> dict[str, Any]:
    """Coverage (a surface, a truthful vendor-init, or truthfully none) and size match rate."""
    if only:
        ok = [r for r in rows if r.descriptor_only_mm is not None or r.verdict == "not a surface"]
        compared = [
            r
            for r in rows
            if r.descriptor_only_mm is not None and r.libinput_mm and r.verdict != "libinput wrong"
        ]
        matched = [
            r
            for r in compared
            if sizes_match(r.descriptor_only_mm or (0, 0), r.libinput_mm or (0, 0))
        ]
    else:
        # libinput-wrong rows have a surface (covered) but no size to compare against.
        ok = [r for r in rows if r.verdict in OK_VERDICTS or r.verdict == "libinput wrong"]
        ok += [r for r in rows if r.verdict == "miss" and r.surface_mm is not None]
        compared = [r for r in rows if r.verdict in ("match", "miss") and r.surface_mm is not None]
        matched = [r for r in compared if r.verdict == "match"]
    return {
        "descriptors": len(rows),
        "covered": len(ok),
        "coverage": len(ok) / len(rows) if rows else 0.0,
        "sizes_compared": len(compared),
        "sizes_matched": len(matched),
        "match_rate": len(matched) / len(compared) if compared else 0.0,
    }


def _by(rows: list[Row], key: str) -> dict[str, dict[str, Any]]:
    groups: dict[str, list[Row]] = {}
    for r in rows:
        k = getattr(r, key) if key != "libinput_kind" else (r.libinput_kind or "none")
        groups.setdefault(str(k), []).append(r)
    return {
        k: {"new": _rates(v), "descriptor_only": _rates(v, only=True)}
        for k, v in sorted(groups.items())
    }


_TOKEN = re.compile(r"[a-z0-9]+")


def _tokens(text: str) -> set[str]:
    return set(_TOKEN.findall(re.sub(r"\(.*?\)", " ", text.lower())))


def _known_size(
    stem: str, name: str, vid_pid: str, coverage: Path | None, tablets: Path | None
) -> tuple[tuple[float, float], str] | None:
    """An independent size for a recording: a coverage capture or an OTD file of the same product.

    Vendors reuse ids across models (Huion 256c:006d is in 62 OTD files), so
    the product name must match too: every word of the oracle's model name is
    in the recording's file name or device name.
    """
    words = _tokens(stem.replace("-", " ")) | _tokens(name)
    if coverage is not None:
        for slug, o in _oracles(coverage):
            if f"{o.get('vid')}:{o.get('pid')}" != vid_pid or not _tokens(o["product"]) <= words:
                continue
            for d in o["libinput"]:
                if d.get("kind") == "tablet" and d.get("size_mm"):
                    return (float(d["size_mm"][0]), float(d["size_mm"][1])), (
                        f"libinput on a real {o['product']} ({slug})"
                    )
    if tablets is not None and (tablets / "otd-tablets.json").is_file():
        otd = json.loads((tablets / "otd-tablets.json").read_text())
        named = []
        for t in otd["tablets"]:
            name_words = _tokens(t["name"])
            if len(name_words) >= 2 and name_words <= words:
                ids = {f"{i['vid']}:{i['pid']}" for i in t["identifiers"]}
                named.append((vid_pid in ids, len(name_words), t))
        if named:
            # The same id first; else the most specific name (UGEE M708 V2, not M708):
            # a model keeps its name when its maker changes its product id.
            same_id, _, t = max(named, key=lambda c: (c[0], c[1]))
            note = "" if same_id else f", another id ({vid_pid} is not listed there)"
            return (float(t["width_mm"]), float(t["height_mm"])), (
                f"OpenTabletDriver {t['file']}{note}"
            )
    return None


def _negatives(data: Path) -> set[str]:
    """Recordings the folder's README lists as negatives ("mouse (negative)", ...)."""
    readme = data / "README.md"
    if not readme.is_file():
        return set()
    out = set()
    for line in readme.read_text().splitlines():
        parts = [p.strip() for p in line.split("|")]
        if len(parts) > 2 and parts[0].startswith("- `") and "negative" in parts[2]:
            out.add(parts[0][3:].split("`", 1)[0])
    return out


def _failed(stem: str, vid_pid: str, reason: str) -> dict[str, Any]:
    return {
        "recording": stem,
        "vid_pid": vid_pid,
        "size_from": None,
        "surface_mm": None,
        "known_mm": None,
        "known_from": None,
        "samples": 0,
        "touching": 0,
        "ok": False,
        "reason": reason,
    }


def recording_rows(
    data: Path, coverage: Path | None, tablets: Path | None, limit: int | None = None
) -> list[dict[str, Any]]:
    """Replay every tablet recording through the daemon's path: contacts, and the right size."""
    from stiction.drivers.hid.facts import describe_device
    from stiction.drivers.hid.playback import open_replay
    from stiction.drivers.hid.recording import load_recording
    from stiction.errors import StictionError

    negatives = _negatives(data)
    rows = []
    for path in sorted(data.glob("*.hid"))[:limit]:
        rec = load_recording(path)
        if not rec.events or path.name in negatives:
            continue  # no reports, or a mouse or keyboard the folder's README names as such
        vid_pid = f"{rec.vid:04x}:{rec.pid:04x}"
        try:
            facts = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
        except StictionError as exc:
            rows.append(_failed(path.stem, vid_pid, f"refused: {exc}"))
            continue
        if facts.kind is None:
            rows.append(_failed(path.stem, vid_pid, facts.problem or "no contact report"))
            continue
        known = _known_size(path.stem, rec.name, vid_pid, coverage, tablets)
        given = None
        if facts.surface_m is None and known is not None:
            given = (known[0][0] / 1000.0, known[0][1] / 1000.0)  # as the live init would
        row: dict[str, Any] = {
            "recording": path.stem,
            "vid_pid": vid_pid,
            "size_from": facts.size_from,
            "surface_mm": _mm(facts.surface_m),
            "known_mm": known[0] if known else None,
            "known_from": known[1] if known else None,
        }
        if facts.surface_m is None and given is None:
            row.update(samples=0, touching=0, ok=False, reason=facts.problem or "no size")
            rows.append(row)
            continue
        try:
            src = open_replay(path, size_m=given)
            samples = list(src.samples())
        except StictionError as exc:
            rows.append(_failed(path.stem, vid_pid, f"replay refused: {exc}"))
            continue
        surface = src.surface_size
        assert surface is not None  # a stream without a size is refused above
        touching = sum(s.tip for s in samples)
        inside = all(0.0 <= s.x <= surface[0] and 0.0 <= s.y <= surface[1] for s in samples)
        # Positions beyond the declared range are clamped onto the surface: many of
        # them would mean the descriptor's range (so its size) is not the device's.
        clamped = src.stream.stats["clamped_positions"]
        reach = (
            max(s.x for s in samples) / surface[0] if samples else 0.0,
            max(s.y for s in samples) / surface[1] if samples else 0.0,
        )
        # A vendor-init tablet is replayed with the known size (the init gives it
        # live), so its size is not checked here, only its contacts.
        checked = known is not None and given is None
        size_ok = known is None or not checked or sizes_match(_mm(surface) or (0, 0), known[0])
        row.update(
            samples=len(samples),
            touching=touching,
            reports=src.stream.stats["reports"],
            size_matches=size_ok if checked else None,
            clamped=clamped,
            reach=reach,
            ok=bool(samples)
            and touching > 0
            and inside
            and size_ok
            and clamped <= MAX_CLAMPED * len(samples),
        )
        if facts.size_from == "vendor-init":
            row["reason"] = "vendor-init: replayed with the known size the tablet gives live"
        elif known is None:
            row["reason"] = "contacts decode; no independent size for this product"
        elif not size_ok:
            row["reason"] = "surface differs from the known size"
        rows.append(row)
    return rows


def descriptor_file_rows(
    data: Path, coverage: Path | None, tablets: Path | None, limit: int | None = None
) -> list[dict[str, Any]]:
    """The files of the recordings folder that hold a descriptor but no reports: their size."""
    from stiction.drivers.hid.facts import describe_device
    from stiction.drivers.hid.recording import load_recording
    from stiction.errors import StictionError

    negatives = _negatives(data)
    rows = []
    for path in sorted(data.glob("*.hid"))[:limit]:
        rec = load_recording(path)
        if rec.events or path.name in negatives:
            continue
        vid_pid = f"{rec.vid:04x}:{rec.pid:04x}"
        try:
            facts = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
        except StictionError as exc:
            rows.append({"file": path.stem, "kind": None, "ok": False, "reason": str(exc)})
            continue
        known = _known_size(path.stem, rec.name, vid_pid, coverage, tablets)
        surface = _mm(facts.surface_m)
        row: dict[str, Any] = {
            "file": path.stem,
            "kind": facts.kind,
            "size_from": facts.size_from,
            "surface_mm": surface,
            "known_mm": known[0] if known else None,
            "known_from": known[1] if known else None,
        }
        if known is None or surface is None:
            row["ok"] = None  # nothing to compare
        else:
            row["ok"] = sizes_match(surface, known[0])
        rows.append(row)
    return rows


def _reach(reach: tuple[float, float] | None) -> str:
    return "-" if reach is None else f"{reach[0]:.0%}/{reach[1]:.0%}"


def _fmt(size: tuple[float, float] | None) -> str:
    return "-" if size is None else f"{size[0]:.1f}x{size[1]:.1f}"


def _table(
    rows: list[Row],
    result: dict[str, Any],
    recs: list[dict[str, Any]],
    files: list[dict[str, Any]],
) -> str:
    head = (
        f"{'descriptor':46s} {'driver':14s} {'kind':11s} {'stiction mm':13s} {'from':11s}"
        f" {'descr-only':13s} {'libinput':13s} verdict"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r.slug[:46]:46s} {str(r.driver)[:14]:14s} {r.kind!s:11s}"
            f" {_fmt(r.surface_mm):13s} {str(r.size_from or '-')[:11]:11s}"
            f" {_fmt(r.descriptor_only_mm):13s} {_fmt(r.libinput_mm):13s} {r.verdict}"
        )
    lines += ["", "Not matched, with the reason:"]
    for r in rows:
        if r.verdict != "match" and r.verdict not in ("vendor-init",):
            lines.append(f"  {r.slug}: {r.verdict}: {r.reason}")
    lines += [
        "",
        f"{'group':28s} {'new: covered':>14s} {'sizes':>11s} {'descr-only':>12s} {'sizes':>11s}",
    ]
    for title, groups in (("driver", result["by_driver"]), ("kind", result["by_kind"])):
        for k, v in [*groups.items()]:
            n, o = v["new"], v["descriptor_only"]
            lines.append(
                f"{title + ' ' + k:28s} {n['covered']:6d}/{n['descriptors']:<4d}"
                f" {n['sizes_matched']:5d}/{n['sizes_compared']:<4d}"
                f" {o['covered']:7d}/{o['descriptors']:<4d}"
                f" {o['sizes_matched']:5d}/{o['sizes_compared']:<4d}"
            )
    new, only = result["new"], result["descriptor_only"]
    met_cov = "met" if new["coverage"] >= TARGET_SURFACE else "NOT met"
    met_match = "met" if new["match_rate"] >= TARGET_MATCH else "NOT met"
    lines += [
        "",
        f"verdicts: {', '.join(f'{k} {v}' for k, v in sorted(result['verdicts'].items()))}",
        f"surface or truthful vendor-init: {new['coverage']:.1%} ({new['covered']}/"
        f"{new['descriptors']}; descriptor only {only['coverage']:.1%}) "
        f"(target >= {TARGET_SURFACE:.0%}: {met_cov})",
        f"sizes matching libinput (libinput-wrong rows listed, not compared): "
        f"{new['match_rate']:.1%} ({new['sizes_matched']}/{new['sizes_compared']}; "
        f"descriptor only {only['match_rate']:.1%}) (target >= {TARGET_MATCH:.0%}: {met_match})",
        "",
        f"{'tablet recording':36s} {'from':11s} {'surface mm':13s} {'known mm':13s}"
        f" {'samples':>7s} {'touching':>8s} {'clamped':>7s} {'reach %':>9s} ok",
    ]
    for rec in recs:
        lines.append(
            f"{rec['recording'][:36]:36s} {str(rec['size_from'])[:11]:11s}"
            f" {_fmt(rec['surface_mm']):13s} {_fmt(rec['known_mm']):13s} {rec['samples']:7d}"
            f" {rec['touching']:8d} {rec.get('clamped', 0):7d}"
            f" {_reach(rec.get('reach')):>9s} {'yes' if rec['ok'] else 'NO'}"
            + (f"  ({rec['reason']})" if rec.get("reason") else "")
        )
    lines += [
        "",
        f"{'descriptor without reports':36s} {'kind':11s} {'from':11s} {'surface mm':13s}"
        f" {'known mm':13s} matches",
    ]
    for d in files:
        match = {True: "yes", False: "NO", None: "-"}[d["ok"]]
        lines.append(
            f"{d['file'][:36]:36s} {d.get('kind')!s:11s} {str(d.get('size_from'))[:11]:11s}"
            f" {_fmt(d.get('surface_mm')):13s} {_fmt(d.get('known_mm')):13s} {match}"
        )
    compared = [d for d in files if d["ok"] is not None]
    lines.append(
        f"descriptors without reports whose size matches a known one: "
        f"{sum(d['ok'] for d in compared)}/{len(compared)}"
    )
    ok = sum(r["ok"] for r in recs)
    checked = [r for r in recs if r.get("size_matches") is not None]
    lines.append(
        f"tablet recordings giving contacts: {ok}/{len(recs)}; of the right size: "
        f"{sum(bool(r['size_matches']) for r in checked)}/{len(checked)} with an independent "
        f"size ({len(recs) - len(checked)} without one or sized by the vendor's init)"
    )
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="stiction bench devices", description=__doc__.split("\n")[0])
    ap.add_argument("--json", action="store_true", help="print the summary as JSON")
    ap.add_argument(
        "--data", metavar="DIR", help="coverage descriptors (default: shared/data/coverage)"
    )
    ap.add_argument(
        "--recordings", metavar="DIR", help="tablet recordings (default: shared/data/hid)"
    )
    ap.add_argument("--limit", type=int, help="only the first N files of each folder (smoke runs)")
    args = ap.parse_args(argv)
    data = shared_data("coverage", args.data)
    recordings = shared_data("hid", args.recordings)
    tablets = data.parent / "tablets"
    with _no_user_table():
        rows = coverage_rows(data, args.limit)
        otd = tablets if tablets.is_dir() else None
        recs = recording_rows(recordings, data, otd, args.limit)
        files = descriptor_file_rows(recordings, data, otd, args.limit)
    result: dict[str, Any] = {
        "new": _rates(rows),
        "descriptor_only": _rates(rows, only=True),
        "verdicts": dict(Counter(r.verdict for r in rows)),
        "by_driver": _by(rows, "driver"),
        "by_kind": _by(rows, "libinput_kind"),
        "recordings_ok": sum(r["ok"] for r in recs),
        "recordings": recs,
        "descriptor_files": files,
        "targets": {"coverage": TARGET_SURFACE, "match_rate": TARGET_MATCH},
        "tolerance": {"relative": TOL_REL, "mm": TOL_MM},
        "devices": [asdict(r) for r in rows],
        "command": "stiction bench devices --json",
    }
    table = _table(rows, result, recs, files)
    (results_dir() / "devices.json").write_text(json.dumps(result, indent=2) + "\n")
    (results_dir() / "devices.txt").write_text(table + "\n")
    if args.json:
        print(
            json.dumps(
                {
                    k: v
                    for k, v in result.items()
                    if k not in ("devices", "recordings", "descriptor_files")
                }
            )
        )
    else:
        print(table)
    return 0
