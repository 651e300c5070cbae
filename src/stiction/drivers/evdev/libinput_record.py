"""Reader for `libinput record` YAML recordings (file format version 1).

The format is documented in libinput's tools/libinput-record.man ("FILE
FORMAT"): ``devices[i].evdev`` holds ``name``, ``id: [bus, vendor, product,
version]``, ``codes: {type: [codes]}``, ``absinfo: {code: [min, max, fuzz,
flat, resolution]}`` and ``properties``; ``devices[i].events`` is a list of
``{evdev: [[sec, usec, type, code, value], ...]}`` frames, each ending in its
SYN_REPORT. Unknown keys are ignored, as the format asks of parsers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from stiction.drivers.evdev.description import EV_ABS, EV_KEY, EV_SYN, AbsAxis, DeviceDescription
from stiction.drivers.evdev.evemu import Event
from stiction.drivers.limits import read_text
from stiction.errors import RecordingError

try:
    _Loader: Any = yaml.CSafeLoader
except AttributeError:  # PyYAML built without libyaml
    _Loader = yaml.SafeLoader


def looks_like(text: str) -> bool:
    """True when the first meaningful line is a YAML key of this format."""
    for line in text.splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        return s.startswith(("version:", "ndevices:", "libinput:", "devices:", "system:"))
    return False


def _int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise RecordingError(f"{where}: expected an integer, got {value!r}")
    return value


def _ints(value: Any, n: int | None, where: str) -> list[int]:
    if not isinstance(value, list) or (n is not None and len(value) != n):
        want = f"a list of {n} integers" if n else "a list of integers"
        raise RecordingError(f"{where}: expected {want}, got {value!r}")
    return [_int(v, where) for v in value]


def parse(
    path: Path, text: str | None = None, device: int | None = None
) -> tuple[DeviceDescription, list[Event]]:
    """The description and events of one device of the recording.

    `device` picks by index; by default the first pen, touchpad or
    touchscreen is taken, so a `libinput record --multiple` file of a
    tablet and a keyboard replays the tablet.
    """
    if text is None:
        text = read_text(path)
    try:
        _refuse_aliases(path, text)
        doc = yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        # PyYAML's messages span lines ("while ...", the problem, "in ..."): one line here
        why = "; ".join(part.strip() for part in str(exc).splitlines() if part.strip())
        raise RecordingError(f"{path}: not valid YAML: {why}") from None
    except RecursionError:
        raise RecordingError(f"{path}: YAML nested too deeply") from None
    if not isinstance(doc, dict):
        raise RecordingError(f"{path}: not a libinput record file (no top-level mapping)")
    version = doc.get("version")
    if version != 1:
        raise RecordingError(f"{path}: libinput record format version {version!r}, expected 1")
    devices = doc.get("devices")
    if not isinstance(devices, list) or not devices:
        raise RecordingError(f"{path}: no 'devices' list")
    if device is not None:
        if not 0 <= device < len(devices):
            raise RecordingError(f"{path}: has {len(devices)} device(s), no device {device}")
        return _parse_device(path, devices[device], device)
    parsed = [_parse_device(path, d, i) for i, d in enumerate(devices)]
    for desc, events in parsed:
        if desc.kind != "other":
            return desc, events
    return parsed[0]


def _refuse_aliases(path: Path, text: str) -> None:
    """libinput writes no anchors or aliases; a file with them is refused before
    it is loaded, because a few aliases expand a 1 MB file into billions of nodes."""
    for event in yaml.parse(text, Loader=_Loader):
        if isinstance(event, yaml.AliasEvent):
            mark = event.start_mark
            line = f":{mark.line + 1}" if mark is not None else ""
            raise RecordingError(f"{path}{line}: YAML aliases (*name) are not allowed here")


def _parse_device(path: Path, dev: Any, index: int) -> tuple[DeviceDescription, list[Event]]:
    where = f"{path}: devices[{index}]"
    if not isinstance(dev, dict) or not isinstance(dev.get("evdev"), dict):
        raise RecordingError(f"{where}: no 'evdev' description")
    ev = dev["evdev"]
    name = ev.get("name")
    if not isinstance(name, str):
        raise RecordingError(f"{where}.evdev.name: missing or not a string")
    ids = _ints(ev.get("id", [0, 0, 0, 0]), 4, f"{where}.evdev.id")
    codes = ev.get("codes") or {}
    if not isinstance(codes, dict):
        raise RecordingError(f"{where}.evdev.codes: expected a mapping of type -> codes")
    by_type = {
        _int(t, f"{where}.evdev.codes"): frozenset(_ints(c or [], None, f"{where}.evdev.codes.{t}"))
        for t, c in codes.items()
    }
    absinfo = ev.get("absinfo") or {}
    if not isinstance(absinfo, dict):
        raise RecordingError(f"{where}.evdev.absinfo: expected a mapping of code -> [min, ...]")
    axes: dict[int, AbsAxis] = {}
    for code in sorted(by_type.get(EV_ABS, frozenset()) | {_int(c, where) for c in absinfo}):
        info = absinfo.get(code)
        if info is None:
            axes[code] = AbsAxis(0, 0, 0)
            continue
        mn, mx, fuzz, flat, res = _ints(info, 5, f"{where}.evdev.absinfo.{code}")
        axes[code] = AbsAxis(0, mn, mx, fuzz, flat, res)
    props = frozenset(_ints(ev.get("properties") or [], None, f"{where}.evdev.properties"))
    udev: dict[str, str] = {}
    u = dev.get("udev")
    if isinstance(u, dict) and isinstance(u.get("properties"), list):
        for item in u["properties"]:
            if isinstance(item, str) and "=" in item:
                k, _, v = item.partition("=")
                udev[k] = v
    desc = DeviceDescription(
        name=name,
        bustype=ids[0],
        vendor=ids[1],
        product=ids[2],
        version=ids[3],
        properties=props,
        keys=by_type.get(EV_KEY, frozenset()),
        axes=axes,
        other={t: c for t, c in by_type.items() if t not in (EV_SYN, EV_KEY, EV_ABS)},
        udev=udev,
    )
    events: list[Event] = []
    raw_events = dev.get("events") or []
    if not isinstance(raw_events, list):
        raise RecordingError(f"{where}.events: expected a list")
    for i, item in enumerate(raw_events):
        if not isinstance(item, dict) or "evdev" not in item:
            continue  # hid reports and libinput events are not evdev input
        frame = item["evdev"]
        if not isinstance(frame, list):
            raise RecordingError(f"{where}.events[{i}].evdev: expected a list of events")
        for j, e in enumerate(frame):
            sec, usec, typ, code, val = _ints(e, 5, f"{where}.events[{i}].evdev[{j}]")
            if not (sec >= 0 and 0 <= usec < 1_000_000 and 0 <= typ <= 0x1F and 0 <= code <= 0x2FF):
                raise RecordingError(f"{where}.events[{i}].evdev[{j}]: impossible event {e}")
            if events and (sec, usec) < events[-1][:2]:
                raise RecordingError(f"{where}.events[{i}].evdev[{j}]: time runs backwards")
            events.append((sec, usec, typ, code, val))
    return desc, events


def header(desc: DeviceDescription, node: str = "/dev/input/event0") -> str:
    """Everything of a one-device recording up to its `events:` key."""
    codes: dict[int, list[int]] = {EV_SYN: [0, 1, 2, 3]}
    if desc.keys:
        codes[EV_KEY] = sorted(desc.keys)
    if desc.axes:
        codes[EV_ABS] = sorted(desc.axes)
    for t, c in desc.other.items():
        codes[t] = sorted(c)
    lines = [
        "version: 1",
        "ndevices: 1",
        "libinput:",
        '  version: "stiction-converter"',
        "devices:",
        f"  - node: {node}",
        "    evdev:",
        f"      # Name: {desc.name}",
        f"      name: {_quote(desc.name)}",
        f"      id: [{desc.bustype}, {desc.vendor}, {desc.product}, {desc.version}]",
        "      codes:",
        *(f"        {t}: [{', '.join(map(str, c))}]" for t, c in sorted(codes.items())),
        "      absinfo:",
        *(
            f"        {code}: [{a.minimum}, {a.maximum}, {a.fuzz}, {a.flat}, {int(a.resolution)}]"
            for code, a in sorted(desc.axes.items())
        ),
        f"      properties: [{', '.join(map(str, sorted(desc.properties)))}]",
        "    events:",
    ]
    return "\n".join(lines) + "\n"


def frame_text(events: list[Event]) -> str:
    """One `- evdev:` entry of the events list (a frame, ending in its SYN_REPORT)."""
    rows = "".join(
        f"        - [{s:3d}, {u:6d}, {t:3d}, {c:3d}, {v:6d}]\n" for s, u, t, c, v in events
    )
    return "      - evdev:\n" + rows


def dump(desc: DeviceDescription, events: list[Event], node: str = "/dev/input/event0") -> str:
    """A whole recording in this format (tests and conversion use it).

    Events are grouped into one ``evdev`` entry per SYN_REPORT, as libinput
    record does; times are written as recorded.
    """
    out = [header(desc, node)]
    frame: list[Event] = []
    for e in events:
        frame.append(e)
        if e[2] == EV_SYN and e[3] == 0:
            out.append(frame_text(frame))
            frame = []
    if frame:
        out.append(frame_text(frame))
    return "".join(out)


def _quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'
