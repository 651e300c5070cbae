"""Open any evdev recording: evemu (combined or .desc + .events) or libinput record YAML.

evemu recordings often come as a description file and a separate events
file (evemu-describe and evemu-record run apart). When only one of the pair
is given, the other is looked up beside it by name (``dev.desc`` pairs with
``dev.events`` or ``dev.<gesture>.events``), so ``replay:PATH`` works with one
path; several candidates are an error that lists them rather than a guess.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from stiction.drivers.evdev import evemu, libinput_record
from stiction.drivers.evdev.description import DeviceDescription
from stiction.drivers.evdev.evemu import Event
from stiction.drivers.limits import read_text
from stiction.errors import RecordingError


@dataclass
class Recording:
    description: DeviceDescription
    events: list[Event]
    path: Path
    events_path: Path


def _read(path: Path) -> str:
    try:
        path.stat()
    except FileNotFoundError:
        raise RecordingError(f"recording not found: {path}") from None
    except IsADirectoryError:
        raise RecordingError(f"{path} is a directory, not a recording") from None
    except OSError as exc:
        raise RecordingError(f"cannot read {path}: {exc.strerror or exc}") from None
    return read_text(path)


def _partner(path: Path, want_events: bool) -> Path:
    """The other half of a .desc/.events pair, found by shared name prefix."""
    d = path.parent
    if want_events:
        stem = path.stem if path.suffix == ".desc" else path.name
        cands = sorted(
            p for p in d.glob(f"{stem}*.events") if p != path and p.name.startswith(stem + ".")
        )
    else:
        parts = path.name.split(".")
        cands = []
        for n in range(len(parts) - 1, 0, -1):
            p = d / (".".join(parts[:n]) + ".desc")
            if p.is_file():
                cands = [p]
                break
    if len(cands) == 1:
        return cands[0]
    half = "events (E: lines)" if want_events else "device description (N:/I:/B:/A: lines)"
    if not cands:
        raise RecordingError(
            f"{path} has no {half}, and no matching "
            f"{'.events' if want_events else '.desc'} file is beside it; give both files"
        )
    names = ", ".join(p.name for p in cands)
    raise RecordingError(f"{path} has no {half}; several candidates ({names}): give one")


def _not_another_kind(path: Path, text: str) -> None:
    """Name the files users hand over by mistake, instead of failing on their first line.

    `stictiond --device replay:FILE` reads every file but .hid as evemu, so a
    `stiction record` .npz was 'unknown line type PK\\x03\\x04...' and a trace CSV
    'unknown line type t,x,y,contact'.
    """
    if text.startswith("PK\x03\x04") or path.suffix == ".npz":
        raise RecordingError(
            f"{path} is a `stiction record` recording (.npz), not a device recording: "
            "publish it with `stiction replay`, or make a trace of it with `stiction trace`"
        )
    if text.split("\n", 1)[0].replace(" ", "").startswith("t,x,y,contact"):
        raise RecordingError(
            f"{path} is a trace CSV, not a device recording: run it with `stiction simulate`"
        )


def load(
    path: str | Path, events_path: str | Path | None = None, device: int | None = None
) -> Recording:
    """Read a recording; malformed input raises RecordingError naming the file and line.

    `device` picks one device of a multi-device libinput recording (default:
    the first pen, touchpad or touchscreen).
    """
    path = Path(path)
    text = _read(path)
    _not_another_kind(path, text)
    if libinput_record.looks_like(text) or path.suffix in (".yml", ".yaml"):
        if events_path is not None:
            raise RecordingError(f"{path} is a libinput record file; it takes no events file")
        yaml_desc, yaml_events = libinput_record.parse(path, text, device)
        return Recording(yaml_desc, yaml_events, path, path)
    if device not in (None, 0):
        raise RecordingError(f"{path} is an evemu recording: it holds one device only")
    first = evemu.parse(path, text)
    desc: DeviceDescription | None = first.description
    events = first.events
    ev_path = path
    if events_path is not None:
        ev_path = Path(events_path)
        second = evemu.parse(ev_path, _read(ev_path))
        if desc is None:
            desc = second.description
        if first.events and second.events:
            raise RecordingError(f"both {path} and {ev_path} contain events; give only one")
        events = first.events or second.events
    elif desc is None:
        partner = _partner(path, want_events=False)
        desc = evemu.parse(partner).description
        path, ev_path = partner, path
    elif not events:
        ev_path = _partner(path, want_events=True)
        events = evemu.parse(ev_path).events
    if desc is None:
        raise RecordingError(f"{path}: no device description (N:/I:/B:/A: lines)")
    return Recording(desc, events, path, ev_path)
