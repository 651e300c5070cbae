"""The device catalogue: every entry, the generator, specificity, precedence, both paths.

Facts come from ../shared/data/tablets/otd-tablets.json (OpenTabletDriver's
configurations) and the recordings in ../shared/data/hid.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path

import pytest
from evdev import ecodes

from stiction.drivers.catalogue import load
from stiction.drivers.catalogue.resolve import catalogue, lookup, merge
from stiction.drivers.catalogue.schema import SIZE_KEYS, parse_entry
from stiction.drivers.evdev import sizes
from stiction.drivers.evdev.description import AbsAxis, DeviceDescription
from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import lookup as hid_lookup
from stiction.drivers.hid.facts import describe_device
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.errors import DeviceError

REPO = Path(__file__).resolve().parents[2]
FACTS = REPO.parent / "shared" / "data" / "tablets" / "otd-tablets.json"


@pytest.fixture(scope="module")
def facts() -> dict[str, object]:
    if not FACTS.is_file():
        pytest.fail(f"OpenTabletDriver facts not found at {FACTS}: clone shared/ beside the repo")
    return dict(json.loads(FACTS.read_text("utf-8")))


def _ident(vid: str, pid: str) -> tuple[int, int]:
    return int(vid, 16), int(pid, 16)


# --- every entry -------------------------------------------------------------


def test_every_entry_loads_and_names_its_source() -> None:
    gen, hand = load.generated(), load.builtin()
    assert len(gen) > 300 and len(hand) >= 9
    for e in gen + hand:
        assert e.source.strip() and e.name.strip(), e
    commit = "ada667ba1527869834b143aa0bf4c32ba6dee836"
    assert all(commit in e.source and "Configurations/" in e.source for e in gen)


def test_generated_sources_name_real_configuration_files(facts: dict[str, object]) -> None:
    files = {t["file"] for t in facts["tablets"]}  # type: ignore[attr-defined]
    for e in load.generated():
        named = e.source.split("Configurations/Configurations/", 1)[1].strip("{}").split(", ")
        assert named and set(named) <= files, e.source


def test_no_two_entries_of_one_file_claim_the_same_match() -> None:
    for entries in (load.generated(), load.builtin()):
        counts = Counter(e.match for e in entries)
        assert [m for m, n in counts.items() if n > 1] == []


def test_a_hand_written_entry_sharing_a_generated_match_is_a_layer_above_it() -> None:
    """The only repeated matches in the whole catalogue are hand-written over generated."""
    by_match = defaultdict(list)
    for e in load.generated() + load.builtin():
        by_match[e.match].append(e.layer)
    repeated = {m: layers for m, layers in by_match.items() if len(layers) > 1}
    assert repeated  # e.g. 256c:006d: the Huion initialisation written by hand
    assert all(sorted(layers) == ["builtin", "generated"] for layers in repeated.values())


def test_every_opentabletdriver_model_is_in_the_catalogue(facts: dict[str, object]) -> None:
    named: set[str] = set()
    for e in load.generated():
        named.add(e.name)
        named.update(e.effects.get("models", []))  # type: ignore[arg-type]
    models = {t["name"] for t in facts["tablets"]}  # type: ignore[attr-defined]
    assert models - named == set()


def test_a_shared_id_never_carries_one_models_size(facts: dict[str, object]) -> None:
    """An entry matching by vid:pid alone has a size only if every model on that id
    is recognised by the id alone and all of them agree on it."""
    per_id: dict[tuple[int, int], list[tuple[object, object]]] = defaultdict(list)
    for t in facts["tablets"]:  # type: ignore[attr-defined]
        for i in t["identifiers"]:
            per_id[_ident(i["vid"], i["pid"])].append(
                (bool(i["device_strings"]), (t["width_mm"], t["height_mm"]))
            )
    checked = 0
    for e in load.generated():
        if e.match.specificity or "size_mm" not in e.effects:
            continue
        records = per_id[(e.match.vid, e.match.pid)]
        assert not any(needs for needs, _ in records), e.name
        assert {size for _, size in records} == {tuple(e.effects["size_mm"])}, e.name  # type: ignore[arg-type]
        checked += 1
    assert checked > 100
    shared = load.generated()
    huion = next(e for e in shared if e.match.id == "256c:006d" and not e.match.strings)
    assert not set(huion.effects) & set(SIZE_KEYS)
    assert len(huion.effects["models"]) > 50  # type: ignore[arg-type]


def test_models_sharing_a_string_match_keep_only_what_they_agree_on() -> None:
    (both,) = [
        e
        for e in load.generated()
        if e.match.id == "256c:006e" and dict(e.match.strings).get(201) == r"HUION_T153_\d{6}$"
    ]
    assert both.effects["models"] == ["Huion WH1409", "Huion WH1409 V2 (Variant 2)"]
    assert "size_mm" not in both.effects  # 350 x 218 and 350.52 x 219.06 mm
    assert both.effects["init"] == "huion-string-descriptor"


# --- the generator -------------------------------------------------------------


def test_the_committed_generated_file_is_current() -> None:
    done = subprocess.run(
        [sys.executable, str(REPO / "tools" / "gen_catalogue.py"), str(FACTS), "--check"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "current" in done.stdout


def test_the_check_notices_changed_facts(tmp_path: Path, facts: dict[str, object]) -> None:
    changed = json.loads(json.dumps(facts))
    changed["tablets"][0]["width_mm"] += 1
    path = tmp_path / "facts.json"
    path.write_text(json.dumps(changed))
    done = subprocess.run(
        [sys.executable, str(REPO / "tools" / "gen_catalogue.py"), str(path), "--check"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1 and "stale" in done.stdout


def test_the_generator_says_so_when_the_facts_are_missing(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, str(REPO / "tools" / "gen_catalogue.py"), str(tmp_path / "no.json")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and "cannot read" in done.stderr
    assert "Traceback" not in done.stderr


def test_the_generator_help_writes_nothing() -> None:
    """`--help` once regenerated otd.json: it must only print the usage."""
    out = REPO / "src" / "stiction" / "drivers" / "catalogue" / "otd.json"
    before = out.stat().st_mtime_ns
    done = subprocess.run(
        [sys.executable, str(REPO / "tools" / "gen_catalogue.py"), "--help"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and "--check" in done.stdout
    assert out.stat().st_mtime_ns == before


# --- matching ------------------------------------------------------------------


def _e(match: dict[str, object], layer: str = "builtin", **effects: object):  # type: ignore[no-untyped-def]
    return parse_entry(
        {"match": match, "name": str(match), "source": "test", **effects}, "t", layer
    )


def test_string_match_beats_the_id_alone_and_adds_to_it() -> None:
    general = _e({"id": "1234:0001"}, init="huion-string-descriptor")
    model = _e({"id": "1234:0001", "strings": {"201": "^M1_"}}, size_mm=[100, 50])
    r = merge([model, general], 0x1234, 1, {201: "M1_0001"})
    assert r is not None and r.entry is model
    assert r.effects == {"init": "huion-string-descriptor", "size_mm": [100, 50]}
    assert r.origin["init"] is general
    other = merge([model, general], 0x1234, 1, {201: "M2_0001"})
    assert other is not None and other.entry is general and "size_mm" not in other.effects
    unknown = merge([model, general], 0x1234, 1, None)  # a recording: no strings
    assert unknown is not None and unknown.entry is general


def test_two_equally_specific_matches_are_ambiguous_and_neither_is_used() -> None:
    a = _e({"id": "1234:0001", "strings": {"201": "^M"}}, size_mm=[100, 50])
    b = _e({"id": "1234:0001", "strings": {"6": "Tab"}}, size_mm=[200, 90])
    base = _e({"id": "1234:0001"}, parser="P")
    r = merge([a, b, base], 0x1234, 1, {201: "M1", 6: "Tablet"})
    assert r is not None and r.entry is base and "size_mm" not in r.effects
    assert merge([a, b], 0x1234, 1, {201: "M1", 6: "Tablet"}) is None
    only_a = merge([a, b, base], 0x1234, 1, {201: "M1", 6: "Pad"})
    assert only_a is not None and only_a.effects["size_mm"] == [100, 50]


def test_name_match_and_hand_written_over_generated() -> None:
    gen = _e({"id": "1234:0001"}, "generated", size_mm=[100, 50], parser="P")
    hand = _e({"id": "1234:0001"}, "builtin", size_mm=[101, 51])
    finger = _e({"id": "1234:0001", "name": "Finger$"}, "builtin", size_mm=[90, 40])
    r = merge([finger, hand, gen], 0x1234, 1, None, "Tablet Finger")
    assert r is not None and r.effects["size_mm"] == [90, 40] and r.effects["parser"] == "P"
    pen = merge([finger, hand, gen], 0x1234, 1, None, "Tablet Pen")
    assert pen is not None and pen.effects["size_mm"] == [101, 51] and pen.entry is hand


def test_a_users_entry_replaces_what_stiction_ships() -> None:
    shipped = _e({"id": "1234:0001", "strings": {"1": "x"}}, "generated", size_mm=[100, 50])
    init = _e({"id": "1234:0001"}, "builtin", init="huion-string-descriptor")
    mine = _e({"id": "1234:0001"}, "user", size_mm=[120, 60])
    r = merge([shipped, init, mine], 0x1234, 1, {1: "x"})
    assert r is not None and r.effects == {"size_mm": [120, 60]} and r.used == (mine,)


def test_real_shared_huion_id_with_and_without_its_firmware_string() -> None:
    """256c:006d is 59 models in OpenTabletDriver; string 201 names the model."""
    bare = hid_lookup(0x256C, 0x006D)
    assert bare is not None and bare.size_m is None and bare.init == "huion-string-descriptor"
    hs610 = hid_lookup(0x256C, 0x006D, {201: "HUION_T194_230101"})
    assert hs610 is not None and hs610.name == "Huion HS610"
    assert hs610.size_m == pytest.approx((0.254, 0.15875))
    # HuionTilt reads hid-uclogic's v2 report 8 (families.OTD_PARSERS)
    assert hs610.parser == "HuionTiltReportParser" and hs610.family == "uclogic-v2"
    assert hs610.init == "huion-string-descriptor"
    assert "Huion/HS610.json" in hs610.source and "DIGImend" in hs610.source


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[[device]]\nmatch = { id = "1:1", strings = { 201 = "(" } }\nsource = "x"', "regular"),
        ('[[device]]\nmatch = { id = "1:1", strings = { x = "a" } }\nsource = "x"', "index"),
        ('[[device]]\nmatch = { id = "1:1", vendor = 1 }\nsource = "x"', "unknown match key"),
        ('[[device]]\nid = "1:1"\nsource = "x"\nsize = [1, 2]', "unknown key"),
        ('[[device]]\nid = "1:1"\nmatch = { id = "1:1" }\nsource = "x"', "not both"),
        ('[[device]]\nid = "1:1"\nsource = "x"\nfamily = "wacom-bpt"', "needs 'max_x'"),
        ('[[device]]\nid = "1:1"\nsource = "x"\noutput_init = ["zz"]', "not hex"),
        ('[[device]]\nid = "12345:1"\nsource = "x"', "out of range"),
    ],
)
def test_bad_entries_are_refused_with_the_reason(text: str, message: str) -> None:
    with pytest.raises(DeviceError, match=message):
        load.parse_toml(text, "overlay.toml", "user")


# --- precedence on real recordings ----------------------------------------------


def test_the_descriptor_wins_over_a_generated_size_that_disagrees(hid_data: Path) -> None:
    """5543:004d is the Yiynova MVP20U+RH in this recording and
    the XP-Pen Artist 16 in OpenTabletDriver: one USB id reused across products.
    The descriptor is this unit's own statement, so it wins."""
    rec = load_recording(hid_data / "yiynova-mvp20u-rh.hid")
    entry = hid_lookup(rec.vid, rec.pid)
    assert entry is not None and entry.size_layer == "generated" and entry.size_m is not None
    assert entry.size_m == pytest.approx((0.34416, 0.19359))  # OpenTabletDriver's Artist 16
    stream = ReportStream(parse_descriptor(rec.descriptor), rec.name, None, entry)
    own = ReportStream(parse_descriptor(rec.descriptor), rec.name).surface_size
    assert own is not None and own[0] > entry.size_m[0] + 0.05  # they disagree by > 5 cm
    assert stream.surface_size == own and stream.size_from == "descriptor"
    samples = [s for ev in rec.events for s in stream.feed(ev.t, ev.data)]
    assert any(s.x > entry.size_m[0] for s in samples)  # real positions beyond the 16-inch area
    d = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
    assert d.size_from == "descriptor" and d.catalogue == "Yiynova MVP20U+RH (UC-Logic)"


def test_a_generated_size_fills_in_where_the_descriptor_has_none(hid_data: Path) -> None:
    """The Inspiroy 2 S recording declares no usable size; given its firmware string
    (as a live open reads it), OpenTabletDriver's H641P entry gives the area."""
    rec = load_recording(hid_data / "huion-inspiroy-2-s-pen.hid")
    bare = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
    assert bare.size_from == "vendor-init" and bare.surface_m is None
    d = describe_device(
        rec.vid, rec.pid, rec.name, rec.descriptor, strings={201: "HUION_T21j_230101"}
    )
    assert d.size_from == "catalogue" and d.catalogue == "Huion H641P"
    assert d.surface_m == pytest.approx((0.16, 0.1))


def test_a_hand_written_size_wins_over_the_descriptor(hid_data: Path) -> None:
    """VEIKK S640: the descriptor's physical maxima are wrong (20.8 x 28.0 mm)."""
    rec = load_recording(hid_data / "veikk-s640.hid")
    d = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
    assert d.size_from == "catalogue" and d.surface_m == pytest.approx((0.1524, 0.1016))


def test_a_users_string_entry_is_config(hid_data: Path, tmp_path: Path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    table = tmp_path / "mine.toml"
    table.write_text(
        '[[device]]\nmatch = { id = "256c:0066", strings = { 201 = "^HUION_T21j" } }\n'
        'name = "my H641P"\nsource = "my ruler"\nsize_mm = [159, 99]\n'
    )
    monkeypatch.setenv("STICTION_HID_DEVICES", str(table))
    rec = load_recording(hid_data / "huion-inspiroy-2-s-pen.hid")
    d = describe_device(
        rec.vid, rec.pid, rec.name, rec.descriptor, strings={201: "HUION_T21j_230101"}
    )
    assert (d.size_from, d.catalogue) == ("config", "my H641P")
    assert d.surface_m == pytest.approx((0.159, 0.099))
    # Without the string the user's entry does not apply; the shipped ones do.
    assert describe_device(rec.vid, rec.pid, rec.name, rec.descriptor).size_from == "vendor-init"


# --- live strings through pyusb -------------------------------------------------


def test_a_live_open_reads_the_strings_the_catalogue_matches_on() -> None:
    sys.path.insert(0, str(REPO / "tests" / "hid"))
    from fake_huion_usb import (  # type: ignore[import-not-found]
        V2,
        HuionUsbBackend,
        string_descriptor,
    )

    from stiction.drivers.catalogue.resolve import string_indices
    from stiction.drivers.hid.hidraw_backend import _usb_strings

    firmware = string_descriptor("HUION_T194_230101".encode("utf-16-le"))
    backend = HuionUsbBackend({200: V2, 201: firmware})
    assert 201 in string_indices(0x256C, 0x006D)
    strings = _usb_strings(0x256C, 0x006D, backend)
    assert strings == {201: "HUION_T194_230101"}
    # Only string descriptors were asked for, and never 200 (it switches the mode).
    asked = {wvalue & 0xFF for _, _, wvalue, _, _ in backend.requests}
    assert 200 not in asked and asked == set(string_indices(0x256C, 0x006D))
    entry = hid_lookup(0x256C, 0x006D, strings)
    assert entry is not None and entry.name == "Huion HS610"
    gone = HuionUsbBackend({}, present=False)
    assert _usb_strings(0x256C, 0x006D, gone) is None  # unplugged: match by id alone


# --- evdev ----------------------------------------------------------------------


def _node(name: str, keys: set[int], vid: int = 0x056A, pid: int = 0x0374) -> DeviceDescription:
    axes = {ecodes.ABS_X: AbsAxis(0, 0, 15200), ecodes.ABS_Y: AbsAxis(0, 0, 9500)}
    return DeviceDescription(name, 3, vid, pid, keys=frozenset(keys), axes=axes)


def test_evdev_pen_node_gets_the_generated_size_a_touch_node_does_not() -> None:
    """Wacom CTL-4100 (Intuos S): 152 x 95 mm in OpenTabletDriver, a pen area."""
    pen = sizes.apply(_node("Wacom Intuos S Pen", {ecodes.BTN_TOOL_PEN, ecodes.BTN_TOUCH}))
    assert pen.axes[ecodes.ABS_X].resolution == pytest.approx(100.0)
    assert pen.axes[ecodes.ABS_Y].resolution == pytest.approx(100.0)
    finger = _node("Wacom Intuos S Finger", {ecodes.BTN_TOOL_FINGER, ecodes.BTN_TOUCH})
    assert sizes.lookup(finger) is None
    with pytest.raises(DeviceError, match="no resolution"):
        sizes.require(sizes.apply(finger))


def test_evdev_hand_written_entries_match_by_name() -> None:
    keys = {ecodes.BTN_TOOL_FINGER, ecodes.BTN_TOUCH}
    finger = sizes.lookup(_node("Wacom Intuos5 touch M Finger", keys, 0x056A, 0x0027))
    assert finger is not None and finger.size_mm == (223.52, 139.70)
    assert finger.name == "Intuos5 touch M Finger"
    assert sizes.lookup(_node("Wacom Intuos5 touch M Pad", keys, 0x056A, 0x0027)) is None


def test_catalogue_lookup_is_empty_for_an_unknown_id() -> None:
    assert lookup(0x1234, 0x5678) is None
    assert all(e.match.vid != 0x1234 or e.match.pid != 0x5678 for e in catalogue())


def test_the_entries_shown_in_the_docs_are_valid_catalogue_entries() -> None:
    sys.path.insert(0, str(REPO / "tests" / "docs"))
    from doc_blocks import parse_page  # type: ignore[import-not-found]

    shown = [
        b
        for page in ("docs/devices.md", "docs/evdev.md")
        for b in parse_page(REPO / page)
        if b.kind == "toml" and "[[device]]" in b.text
    ]
    assert len(shown) >= 4
    for block in shown:
        assert load.parse_toml(block.text, block.id, "user"), block.id


def test_a_failing_generated_huion_init_falls_back_to_the_descriptor() -> None:
    """256c:0064 asks for the Huion init only in OpenTabletDriver's facts: when the
    USB read fails, the device is read as its descriptor says instead of refusing
    to open; a hand-written init (256c:006d) still fails loudly."""
    sys.path.insert(0, str(REPO / "tests" / "hid"))
    from fake_huion_usb import HuionUsbBackend

    from stiction.drivers.hid.hidraw_backend import _vendor_init

    generated = hid_lookup(0x256C, 0x0064)
    assert generated is not None and generated.init == "huion-string-descriptor"
    assert generated.init_layer == "generated"
    absent = HuionUsbBackend({}, present=False, pid=0x0064)
    init = _vendor_init(None, generated, absent)
    assert init.size_m is None and init.descriptor is None and init.fixup is None
    written = hid_lookup(0x256C, 0x006D)
    assert written is not None and written.init_layer == "builtin"
    with pytest.raises(DeviceError, match="not found"):
        _vendor_init(None, written, HuionUsbBackend({}, present=False))


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "stiction", "hid", "describe", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_describe_takes_the_usb_strings_a_recording_lacks(hid_data: Path) -> None:
    path = str(hid_data / "huion-inspiroy-2-s-pen.hid")
    done = _cli(path, "--json", "--usb-string", "201=HUION_T21j_230101")
    assert done.returncode == 0, done.stderr
    device = json.loads(done.stdout)["device"]
    assert (device["size_from"], device["catalogue"]) == ("catalogue", "Huion H641P")
    text = _cli(path, "--usb-string", "201=HUION_T21j_230101")
    assert "from the catalogue (Huion H641P)" in text.stdout
    bad = _cli(path, "--usb-string", "two hundred")
    assert bad.returncode == 2 and "INDEX=TEXT" in bad.stderr and "Traceback" not in bad.stderr


def test_evdev_kernel_resolution_wins_and_the_catalogue_fills_in_without_it(
    evdev_data: Path,
) -> None:
    """UC-Logic WP5540U pen node (5543:0004): the kernel says 235 units/mm; with the
    resolution gone (an old kernel), OpenTabletDriver's 139.7 x 101.6 mm applies."""
    from stiction.drivers.evdev.recording import load as load_evdev

    desc = load_evdev(evdev_data / "uc-logic-wp5540u-pen.evemu").description
    x, y = desc.position_codes
    assert sizes.apply(desc).axes[x].resolution == desc.axes[x].resolution == 235
    entry = sizes.lookup(desc)
    assert entry is not None and "OpenTabletDriver" in entry.source
    old = sizes.apply(desc.with_resolution(0, 0))
    width = (old.axes[x].maximum - old.axes[x].minimum) / old.axes[x].resolution
    height = (old.axes[y].maximum - old.axes[y].minimum) / old.axes[y].resolution
    assert (width, height) == pytest.approx((139.6873, 101.5873), abs=0.01)
    # The kernel's own figure for this node is within 0.3 mm of OpenTabletDriver's.
    kernel_w = (desc.axes[x].maximum - desc.axes[x].minimum) / 235
    assert abs(kernel_w - width) < 0.3


def test_every_entry_becomes_a_working_hid_entry() -> None:
    """Each entry alone, as the HID path sees it: a family's generated descriptor
    parses and gives a pen stream of the entry's size; every init report is hex."""
    from stiction.drivers.catalogue.resolve import Resolved
    from stiction.drivers.hid.devices import from_resolved

    families = variants = 0
    for e in load.generated() + load.builtin():
        r = Resolved(e, e.effects, dict.fromkeys(e.effects, e), (e,))
        entries = [from_resolved(r)]
        # and each report length's family, on an interface declaring that length
        for length in e.effects.get("by_report_length", {}):  # type: ignore[attr-defined]
            entries.append(from_resolved(r, _vendor((9, int(length)))))
            assert entries[-1].family is not None, (e.name, length)
            variants += 1
        for entry in entries:
            assert entry.name == e.name and entry.source == e.source
            if entry.family is not None:
                families += 1
                assert entry.descriptor is not None and entry.size_m is not None
                stream = ReportStream(parse_descriptor(entry.descriptor), e.name, None, entry)
                assert stream.kind == "pen" and stream.size_from == "catalogue"
                assert stream.surface_size == pytest.approx(entry.size_m, abs=1e-5)
    assert families >= 60 and variants >= 20


def test_a_pen_family_stays_off_another_interface_of_the_same_id(hid_data: Path) -> None:
    """Wacom PTZ-630 (Intuos3 6x8, 056a:00b1): its pen interface's descriptor
    (linuxwacom/wacom-hid-descriptors, in shared/data/coverage) declares report 2 of
    10 bytes, the length OpenTabletDriver matches; a touch interface sharing the id
    (here a real touchpad descriptor given that id) keeps its own descriptor."""
    pen = load_recording(REPO.parent / "shared/data/coverage/wacom-intuos3-6x8-056a00b1-1.hid")
    facts = describe_device(pen.vid, pen.pid, pen.name, pen.descriptor)
    assert (facts.kind, facts.size_from, facts.catalogue) == ("pen", "catalogue", "Wacom PTZ-630")
    assert facts.surface_m == pytest.approx((0.2032, 0.1524))
    entry = hid_lookup(pen.vid, pen.pid, descriptor=pen.descriptor)
    assert entry is not None and entry.family == "wacom-intuos"
    touch = load_recording(hid_data / "elan-04f3-3140-touchpad.hid").descriptor
    other = describe_device(pen.vid, pen.pid, "Wacom touch", touch)
    assert (other.kind, other.size_from, other.catalogue) == (
        "touchpad",
        "descriptor",
        "Wacom PTZ-630",
    )
    off = hid_lookup(pen.vid, pen.pid, descriptor=touch)
    assert off is not None and off.family is None and off.descriptor is None


def test_hid_devices_match_by_their_product_name(
    hid_data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """UGEE M708 v2 (28bd:0907) is "10 inch PenTablet" in its recording."""
    table = tmp_path / "mine.toml"
    table.write_text(
        '[[device]]\nmatch = { id = "28bd:0907", name = "^10 inch PenTablet$" }\n'
        'name = "M708 by name"\nsource = "my ruler"\nsize_mm = [250, 150]\n'
        '[[device]]\nmatch = { id = "28bd:0907", name = "Artist" }\n'
        'name = "not this one"\nsource = "my ruler"\nsize_mm = [100, 100]\n'
    )
    monkeypatch.setenv("STICTION_HID_DEVICES", str(table))
    rec = load_recording(hid_data / "ugee-m708-v2.hid")
    d = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
    assert (d.size_from, d.catalogue) == ("config", "M708 by name")
    assert d.surface_m == pytest.approx((0.25, 0.15))
    from stiction.drivers.hid.playback import open_replay

    assert open_replay(hid_data / "ugee-m708-v2.hid").surface_size == pytest.approx((0.25, 0.15))
    other = describe_device(rec.vid, rec.pid, "another tablet", rec.descriptor)
    assert (other.size_from, other.catalogue) == ("descriptor", "XP-Pen Star 03")


def test_the_users_overlay_sizes_an_evdev_node(tmp_path: Path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    keys = {ecodes.BTN_TOOL_FINGER, ecodes.BTN_TOUCH}
    node = _node("Acme Pad Finger", keys, 0x1234, 0x0001)
    assert sizes.lookup(node) is None
    table = tmp_path / "mine.toml"
    table.write_text(
        '[[device]]\nmatch = { id = "1234:0001", name = "Finger$" }\n'
        'source = "my ruler"\nsize_mm = [152, 95]\n'
    )
    monkeypatch.setenv("STICTION_HID_DEVICES", str(table))
    fixed = sizes.apply(node)
    assert fixed.axes[ecodes.ABS_X].resolution == pytest.approx(100.0)


def test_the_hand_written_tables_header_names_every_family() -> None:
    """The header of devices.toml is where people adding a device read the keys."""
    from stiction.drivers.hid.families import FAMILIES

    header = (
        Path(__file__).resolve().parents[2] / "src/stiction/drivers/catalogue/devices.toml"
    ).read_text(encoding="utf-8")
    header = header[: header.index("[[device]]")]
    missing = [f for f in FAMILIES if f'"{f}"' not in header]
    assert not missing, f"devices.toml's header does not list {missing}"


# --- models told apart by their report length -------------------------------------


def _vendor(*reports: tuple[int, int]) -> bytes:
    """A vendor interface's descriptor: per (report ID, length in bytes with the ID), a
    collection of that many vendor bytes (Usage Page 0xff0a), no pen usage."""
    return b"".join(
        bytes.fromhex(f"060aff0901a10185{rid:02x}750895{n - 1:02x}150026ff0009018102c0")
        for rid, n in reports
    )


def test_each_report_length_gets_the_family_its_models_agree_on(
    facts: dict[str, object],
) -> None:
    """VEIKK S640 (13-byte reports) and S640 V2 (9-byte) share 2feb:0001: the id-only
    entry names no family, but a family per length, each with facts that every
    OpenTabletDriver identifier of that length agrees on."""
    (s640,) = [e for e in load.generated() if e.match.id == "2feb:0001" and not e.match.strings]
    assert "family" not in s640.effects
    variants = s640.effects["by_report_length"]
    assert {k: v["family"] for k, v in variants.items()} == {"9": "veikk-v1", "13": "veikk-vk"}  # type: ignore[attr-defined]
    per_length: dict[tuple[int, int, int], set[tuple[object, ...]]] = defaultdict(set)
    for t in facts["tablets"]:  # type: ignore[attr-defined]
        for i in t["identifiers"]:
            key = (*_ident(i["vid"], i["pid"]), i["input_report_length"])
            per_length[key].add((t["width_mm"], t["height_mm"], t["max_x"], t["max_y"]))
    checked = 0
    for e in load.generated():
        for length, sub in e.effects.get("by_report_length", {}).items():  # type: ignore[attr-defined]
            assert sub["report_length"] == int(length)
            if e.match.strings:
                continue  # a string match's records are a subset of the id's
            full = {**e.effects, **sub}  # a variant leaves out what the entry says already
            sizes_seen = per_length[(e.match.vid, e.match.pid, int(length))]
            assert sizes_seen == {(*full["size_mm"], full["max_x"], full["max_y"])}, e.name
            checked += 1
    assert checked >= 15


@pytest.mark.parametrize(
    ("reports", "family"),
    [
        (((9, 13),), "veikk-vk"),
        (((9, 9),), "veikk-v1"),
        (((9, 9), (10, 13)), None),  # both lengths on one interface: neither model
        (((9, 12),), None),  # no length fits
    ],
)
def test_the_interfaces_descriptor_picks_the_length(
    reports: tuple[tuple[int, int], ...], family: str | None
) -> None:
    entry = hid_lookup(0x2FEB, 0x0001, descriptor=_vendor(*reports))
    assert entry is not None and entry.family == family
    if family is not None:
        assert entry.geometry is not None and entry.size_m is not None
        assert entry.init_reports  # the vendor mode is asked for only with a family
    else:
        assert entry.geometry is None and entry.init_reports == ()
    # without a descriptor (a udev rule, an evdev node) no length can be told
    bare = hid_lookup(0x2FEB, 0x0001)
    assert bare is not None and bare.family is None


def test_a_length_the_interface_reads_as_a_pen_is_not_the_vendor_report(
    hid_data: Path,
) -> None:
    """The Parblo Ninos M (0483:a005) has a 10-byte XP-Pen vendor report; on an
    interface whose 10-byte report is a pen it already reads (the real XP-Pen
    Artist 24's firmware descriptor, report 7), the family stays off."""
    own = load_recording(hid_data / "xp-pen-artist-24.hid").descriptor
    desc = parse_descriptor(own)
    assert 10 in {r.byte_size for r in desc.input_reports.values()}
    entry = hid_lookup(0x0483, 0xA005, descriptor=own)
    assert entry is not None and entry.family is None
    vendor = hid_lookup(0x0483, 0xA005, descriptor=_vendor((2, 10)))
    assert vendor is not None and vendor.family == "xp-pen"


@pytest.mark.parametrize(
    ("variants", "message"),
    [
        ("by_report_length = 3", "must be a table"),
        ("by_report_length = {}", "must be a table"),
        ('by_report_length = { x = { parser = "p" } }', "not a report length"),
        ('by_report_length = { 0 = { parser = "p" } }', "1..65535"),
        ("by_report_length = { 9 = 1 }", "table of effects"),
        ('by_report_length = { 9 = { models = ["a"] } }', "cannot be set per report length"),
        ("by_report_length = { 9 = { by_report_length = { 9 = {} } } }", "cannot be set"),
        ("by_report_length = { 9 = { report_length = 10 } }", "must be 9"),
        ('by_report_length = { 9 = { family = "veikk-v1" } }', r"by_report_length\.9.*needs"),
        ("by_report_length = { 9 = { size = 1 } }", "unknown key"),
    ],
)
def test_bad_report_length_variants_are_refused_with_the_reason(
    variants: str, message: str
) -> None:
    text = f'[[device]]\nid = "1:1"\nsource = "x"\n{variants}\n'
    with pytest.raises(DeviceError, match=message):
        load.parse_toml(text, "overlay.toml", "user")


def test_a_variant_completes_the_entrys_own_facts() -> None:
    """A hand-written entry may give the size once and only the family per length."""
    text = (
        '[[device]]\nid = "1:1"\nsource = "x"\nmax_x = 100\nmax_y = 100\n'
        "max_pressure = 255\nsize_mm = [10, 10]\n"
        '[device.by_report_length.9]\nfamily = "veikk-v1"\n'
    )
    (e,) = load.parse_toml(text, "overlay.toml", "user")
    from stiction.drivers.catalogue.resolve import Resolved
    from stiction.drivers.hid.devices import from_resolved

    r = Resolved(e, e.effects, dict.fromkeys(e.effects, e), (e,))
    entry = from_resolved(r, _vendor((9, 9)))
    assert entry.family == "veikk-v1" and entry.size_m == pytest.approx((0.01, 0.01))
    assert from_resolved(r, _vendor((9, 13))).family is None


@pytest.mark.parametrize(
    ("maximum", "resolution"),
    [(2**31 - 1, 1), (15200, 100_000)],  # 2,147 km wide; 0.15 mm wide
)
def test_an_evdev_size_no_surface_has_is_taken_as_none(
    maximum: int, resolution: int, caplog: pytest.LogCaptureFixture
) -> None:
    """An evemu file claiming a 2,147 km axis was read as that: the pointer moved by
    nothing. A size outside 1 mm..10 m a side is taken as no size: the catalogue
    fills in where it knows the device, else opening it asks for one."""
    keys = {ecodes.BTN_TOOL_PEN, ecodes.BTN_TOUCH}
    axes = {
        ecodes.ABS_X: AbsAxis(0, 0, maximum, resolution=resolution),
        ecodes.ABS_Y: AbsAxis(0, 0, 9500, resolution=100),
    }
    unknown = DeviceDescription("Acme Pen", 3, 0x1234, 0x0001, keys=frozenset(keys), axes=axes)
    assert not sizes.kernel_size_plausible(unknown)
    with pytest.raises(DeviceError, match="surface, which no device has"):
        sizes.require(sizes.apply(unknown))
    assert "implausible_size" in caplog.text
    # the same node of a device the catalogue knows (Wacom CTL-4100: 152 x 95 mm)
    known = DeviceDescription(
        "Wacom Intuos S Pen", 3, 0x056A, 0x0374, keys=frozenset(keys), axes=axes
    )
    fixed = sizes.apply(known)
    x = fixed.axes[ecodes.ABS_X]
    assert (x.maximum - x.minimum) / x.resolution == pytest.approx(152.0, rel=0.01)
    # a size given by the user still wins
    assert sizes.apply(unknown, (150.0, 95.0)).axes[ecodes.ABS_X].resolution > 0
