"""Hot-plug with the production evdev driver under umockdev: unplug, then plug back.

The daemon runs in a subprocess under umockdev's preload library with a mocked
/dev/input/event5 (files generated from a shared recording by the evdev
tests' helper). A GI controller (the evdev tests' unplug controller, system
python3 under umockdev-wrapper) replays the events, unplugs the device
(remove uevent, ENODEV on read) and plugs it back as event6 with an "add"
uevent. The daemon must end the contact with phase "up", keep running, and
reopen the device by name when udev announces it -- through its own pyudev
monitor, not through anything the test calls.
"""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path

import pytest

EVDEV_TESTS = Path(__file__).resolve().parents[1] / "evdev"
sys.path.insert(0, str(EVDEV_TESTS))

from evdev_mockfiles import gi_available, run_controller, write_replug_pair  # noqa: E402

from stiction.drivers.evdev.playback import ReplaySource  # noqa: E402
from stiction.drivers.evdev.recording import load  # noqa: E402

READER = textwrap.dedent(
    """
    import json, sys, threading
    from stiction.daemon.devices import DeviceConfig
    from stiction.daemon.options import Options
    from stiction.daemon.service import Daemon

    EXPECTED = {expected}
    opts = Options(pub="ipc://{tmp}/pub", control="ipc://{tmp}/ctl",
                   devices=[DeviceConfig("name:Wacom Cintiq 13HD touch Pen")])
    d = Daemon(opts)
    d.open()
    slot = d.slots[0]
    replugged = threading.Event()
    threading.Thread(target=lambda: sys.stdin.readline() and replugged.set(), daemon=True).start()
    phase = ["wait"]

    def on_tick(n):
        f = d.last_frames.get(slot.name)
        fresh = f is not None and f["tick"] == n
        if phase[0] == "wait" and slot.samples >= EXPECTED:
            phase[0] = "unplug"
            print(json.dumps([slot.samples]), flush=True)
        elif phase[0] == "unplug" and fresh and any(c["phase"] == "up" for c in f["contacts"]):
            phase[0] = "gone"
            print(json.dumps({{"error": "gone", "frame": f}}), flush=True)
        # The tick that ended the device also let it go; with no device left
        # the daemon idles (no ticks) until the hot-plug watcher wakes it.
        if phase[0] == "gone" and slot.run is None:
            phase[0] = "absent"
            print(json.dumps({{"reopen_failed": slot.state}}), flush=True)
        elif phase[0] == "absent" and replugged.is_set() and fresh:
            phase[0] = "done"
            back = {{"reopened": slot.reopened, "devices": d.devices(), "frame": f}}
            print(json.dumps(back), flush=True)
            d.request_stop()

    d.on_tick = on_tick
    print("ready", flush=True)
    try:
        d.run()
    finally:
        d.close()
    """
)


@pytest.mark.umockdev
@pytest.mark.skipif(not gi_available(), reason="needs system python3 with gi + UMockdev typelib")
def test_unplugged_tablet_ends_its_contact_and_is_reopened_on_udev_add(
    evdev_data: Path, tmp_path: Path
) -> None:
    name = "wacom-cintiq-13hd-touch-pen.evemu"
    rec = load(evdev_data / name)
    write_replug_pair(rec, tmp_path, 40, {"ID_INPUT_TABLET": "1"})  # the pen still in range at 40
    # The live driver reads one sample per frame; the replay adds an end-of-stream one.
    expected = sum(1 for _ in ReplaySource(rec).samples()) - 1
    assert expected == 40
    reader = READER.format(expected=expected, tmp=tmp_path)
    out = run_controller(tmp_path, reader, "1", timeout=90)
    lines = out["reader"]
    assert lines[0] == "ready", out
    gone = [json.loads(x) for x in lines if x.startswith('{"error"')]
    assert len(gone) == 1, out
    contacts = gone[0]["frame"]["contacts"]
    assert [c["phase"] for c in contacts] == ["up"]
    assert contacts[0]["pointer_m"] == contacts[0]["touch_m"]
    back = [json.loads(x) for x in lines if x.startswith('{"reopened"')]
    assert len(back) == 1, out
    assert back[0]["reopened"] == 1
    assert back[0]["devices"][0]["state"] == "open"
    assert back[0]["frame"]["device"] == gone[0]["frame"]["device"]
    assert out["returncode"] == 0, out["stderr"]
