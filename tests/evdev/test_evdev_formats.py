"""libinput record YAML, malformed recordings, and the `stiction evdev` commands."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

from stiction.cli import main
from stiction.drivers.evdev import libinput_record, replay, sizes
from stiction.drivers.evdev.frames import FrameAssembler
from stiction.drivers.evdev.recording import load
from stiction.errors import RecordingError

# Written by hand after the FILE FORMAT section of libinput's
# tools/libinput-record.man: comments, a hid entry and keys a parser must ignore.
HAND_YAML = textwrap.dedent(
    """\
    # libinput record
    version: 1
    ndevices: 1
    libinput:
      version: 1.25.0
      git: "unknown"
    system:
      os: "debian:12"
      kernel: "6.1.0"
      dmi: "dmi:bvnLENOVO:"
    devices:
      - node: /dev/input/event7
        evdev:
          # Name: Test Synaptics
          # Size in mm: 100x50
          name: "Test Synaptics"
          id: [29, 1739, 0, 0]
          codes:
            0: [0, 1, 2, 3, 4] # EV_SYN
            1: [272, 325, 328, 330, 333] # EV_KEY
            3: [0, 1, 24, 47, 53, 54, 57, 58] # EV_ABS
          absinfo:
            0: [0, 4000, 0, 0, 40]
            1: [0, 2000, 0, 0, 40]
            24: [0, 255, 0, 0, 0]
            47: [0, 4, 0, 0, 0]
            53: [0, 4000, 0, 0, 40]
            54: [0, 2000, 0, 0, 40]
            57: [0, 65535, 0, 0, 0]
            58: [0, 255, 0, 0, 0]
          properties: [0, 2]
        hid: [5, 1, 9, 2]
        udev:
          properties:
          - ID_INPUT=1
          - ID_INPUT_TOUCHPAD=1
        quirks:
          - AttrSizeHint=100x50
        events:
          - hid:
              time: [0, 0]
              hidraw0: [1, 2, 3]
          - evdev:
            - [  0,      0,   3,  47,     0] # EV_ABS / ABS_MT_SLOT 0
            - [  0,      0,   3,  57,  1420] # EV_ABS / ABS_MT_TRACKING_ID 1420
            - [  0,      0,   3,  53,  1200] # EV_ABS / ABS_MT_POSITION_X 1200
            - [  0,      0,   3,  54,   400] # EV_ABS / ABS_MT_POSITION_Y 400
            - [  0,      0,   3,  58,    51] # EV_ABS / ABS_MT_PRESSURE 51
            - [  0,      0,   1, 330,     1] # EV_KEY / BTN_TOUCH 1
            - [  0,      0,   1, 325,     1] # EV_KEY / BTN_TOOL_FINGER 1
            - [  0,      0,   0,   0,     0] # ------------ SYN_REPORT (0) ------- +0ms
          - evdev:
            - [  0,  11879,   3,  53,  1240] # EV_ABS / ABS_MT_POSITION_X 1240
            - [  0,  11879,   0,   0,     0] # ------------ SYN_REPORT (0) ------- +11ms
          - evdev:
            - [  0,  23001,   3,  57,    -1] # EV_ABS / ABS_MT_TRACKING_ID -1
            - [  0,  23001,   1, 330,     0] # EV_KEY / BTN_TOUCH 0
            - [  0,  23001,   1, 325,     0] # EV_KEY / BTN_TOOL_FINGER 0
            - [  0,  23001,   0,   0,     0] # ------------ SYN_REPORT (0) ------- +12ms
    """
)


def test_hand_written_libinput_record(tmp_path: Path) -> None:
    p = tmp_path / "touchpad.yml"
    p.write_text(HAND_YAML)
    src = replay(p)
    assert src.kind == "touchpad" and src.surface_size == pytest.approx((0.1, 0.05))
    got = [(s.t, s.x, s.y, s.tip, s.in_range, s.contact) for s in src.samples()]
    assert got == [
        (0.0, pytest.approx(0.03), pytest.approx(0.01), True, True, 1420),
        (0.011879, pytest.approx(0.031), pytest.approx(0.01), True, True, 1420),
        (0.023001, pytest.approx(0.031), pytest.approx(0.01), False, False, 1420),
    ]
    assert load(p).description.udev["ID_INPUT_TOUCHPAD"] == "1"


@pytest.mark.parametrize(
    "name",
    [
        "wacom-cintiq-13hd-touch-pen.evemu",
        "cypress-trackpad.two-finger-press.evemu",
        "wacom-intuos4-6x9.desc",
        "synaptics-touchpad.hp8470p.desc",
    ],
)
def test_libinput_record_roundtrip_equals_evemu(
    evdev_data: Path, tmp_path: Path, name: str
) -> None:
    rec = load(evdev_data / name)
    p = tmp_path / "rec.yml"
    p.write_text(libinput_record.dump(rec.description, rec.events))
    back = load(p)
    assert back.events == rec.events
    a = FrameAssembler(sizes.apply(rec.description)).feed_all(rec.events)
    b = FrameAssembler(sizes.apply(back.description)).feed_all(back.events)
    assert a == b


BAD_EVEMU = [
    ("E: 0.1 0003 0000\n", "an event needs"),
    ("E: x.1 0003 0000 5\n", "bad event time"),
    ("E: 0.1000000 0003 0000 5\n", "microseconds"),
    ("E: 0.1 0099 0000 5\n", "out of range"),
    ("E: 0.1 0003 0000 99999999999\n", "32-bit"),
    ("N: X\nA: 00 0 zz 0 0\n", "invalid literal"),
    ("N: X\nA: 00 0 1\n", "A: needs"),
    ("Q: what\n", "unknown line type"),
    ("B: 03 ff\n", "no 'N:'"),
]


@pytest.mark.parametrize(("text", "why"), BAD_EVEMU)
def test_malformed_evemu_is_a_clear_error(tmp_path: Path, text: str, why: str) -> None:
    p = tmp_path / "bad.evemu"
    p.write_text(text)
    with pytest.raises(RecordingError, match=why) as info:
        load(p, tmp_path / "bad.evemu") if text.startswith("N") else load(p)
    assert str(p) in str(info.value)


BAD_YAML = [
    ("version: 1\ndevices: [\n", "not valid YAML"),
    ("version: 2\ndevices: []\n", "version 2"),
    ("version: 1\ndevices: []\n", "no 'devices'"),
    ("version: 1\ndevices:\n  - node: x\n", "no 'evdev'"),
    ("version: 1\ndevices:\n  - evdev: {name: 3}\n", "name"),
    ("version: 1\ndevices:\n  - evdev: {name: a, absinfo: {0: [1, 2]}}\n", "absinfo.0"),
    (
        "version: 1\ndevices:\n  - evdev: {name: a}\n    events:\n"
        "      - evdev: [[0, 2000000, 0, 0, 0]]\n",
        "impossible event",
    ),
    (
        "version: 1\ndevices:\n  - evdev: {name: a}\n    events:\n      - evdev: [[0, 0, 0, 0]]\n",
        "list of 5",
    ),
]


@pytest.mark.parametrize(("text", "why"), BAD_YAML)
def test_malformed_libinput_record_is_a_clear_error(tmp_path: Path, text: str, why: str) -> None:
    p = tmp_path / "bad.yml"
    p.write_text(text)
    with pytest.raises(RecordingError, match=why):
        load(p)


def test_truncated_recording_decodes_what_is_there(evdev_data: Path, tmp_path: Path) -> None:
    """A recording cut mid-frame: the partial frame is not reported, the rest is."""
    text = (evdev_data / "wacom-cintiq-13hd-touch-pen.evemu").read_text()
    lines = text.splitlines(keepends=True)
    cut = next(i for i, ln in enumerate(lines) if ln.startswith("E:")) + 12
    p = tmp_path / "cut.evemu"
    p.write_text("".join(lines[:cut]))
    src = replay(p)
    samples = list(src.samples())
    assert len(samples) == 2 and samples[-1].in_range is False  # one frame, then its end


# -- CLI ------------------------------------------------------------------------


def test_decode_json_matches_architecture_schema(
    evdev_data: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert (
        main(
            [
                "evdev",
                "decode",
                str(evdev_data / "cypress-trackpad.two-finger-press.evemu"),
                "--json",
            ]
        )
        == 0
    )
    rows = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert len(rows) == 37
    keys = {"slot", "tracking_id", "tool", "x", "y", "x_m", "y_m", "pressure", "tip"}
    assert all(set(r) == {"time", "contacts"} for r in rows)
    assert all(set(c) == keys for r in rows for c in r["contacts"])
    first = rows[0]
    assert first["time"] == 1382570965.735216
    assert first["contacts"] == [
        {
            "slot": 0,
            "tracking_id": 395,
            "tool": "finger",
            "x": 762,
            "y": 288,
            "x_m": 762 / 16 / 1000,
            "y_m": 288 / 15 / 1000,
            "pressure": 39 / 255,
            "tip": True,
        }
    ]
    assert rows[-1]["contacts"] == []


def test_decode_pair_and_null_metres(evdev_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    desc = evdev_data / "synaptics-touchpad.hp8470p.desc"
    events = evdev_data / "synaptics-touchpad.hp8470p.two-finger-scroll-horizontal.events"
    assert main(["evdev", "decode", str(desc), str(events), "--json"]) == 0
    rows = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert len(rows) == 150
    c = rows[0]["contacts"][0]
    assert c["x_m"] is None and c["y_m"] is None and c["pressure"] is None
    assert main(["evdev", "decode", str(desc), str(events), "--json", "--size-mm", "100x60"]) == 0
    rows = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert rows[0]["contacts"][0]["x_m"] == pytest.approx((1972 - 1472) / (4256 / 100) / 1000)


def test_decode_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "bad.evemu"
    p.write_text("E: 0.1 0003\n")
    assert main(["evdev", "decode", str(p), "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.evemu:1" in err and "Traceback" not in err


def test_describe(evdev_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evdev", "describe", str(evdev_data / "wacom-intuos4-6x9.desc"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["kind"] == "pen" and info["size_source"] == "device table"
    assert info["size_m"] == pytest.approx([0.22352, 0.1397])


# -- random input to the parsers: a RecordingError or a result, nothing else ----------

from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_tokens = st.sampled_from(
    [
        "E:",
        "N:",
        "I:",
        "P:",
        "B:",
        "A:",
        "#",
        "0",
        "1",
        "-1",
        "03",
        "0003",
        "ff",
        "zz",
        "0.1",
        "1.000001",
        "99999999999",
        "1.2.3",
        "# Event code 0 (ABS_X)",
        "#   Value 7",
        " ",
        "\t",
    ]
)
_lines = st.lists(st.lists(_tokens, max_size=7).map(" ".join), max_size=30).map("\n".join)


@given(text=_lines)
def test_random_evemu_text_never_crashes(
    tmp_path_factory: pytest.TempPathFactory, text: str
) -> None:
    p = tmp_path_factory.mktemp("rnd") / "x.evemu"
    p.write_text(text)
    try:
        rec = load(p, p)
    except RecordingError:
        return
    FrameAssembler(rec.description).feed_many(rec.events)


_yaml_values = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-5, 70000), st.text(max_size=5)),
    lambda inner: st.one_of(
        st.lists(inner, max_size=6),
        st.dictionaries(
            st.sampled_from(
                [
                    "version",
                    "devices",
                    "evdev",
                    "name",
                    "id",
                    "codes",
                    "absinfo",
                    "properties",
                    "events",
                    "udev",
                    0,
                    1,
                    3,
                    47,
                    53,
                ]
            ),
            inner,
            max_size=6,
        ),
    ),
    max_leaves=30,
)


_event = st.tuples(
    st.integers(0, 3),
    st.integers(0, 999999),
    st.sampled_from([0, 1, 3, 4]),
    st.sampled_from([0, 1, 2, 3, 24, 47, 53, 54, 57, 58, 320, 325, 330]),
    st.one_of(st.integers(-2, 3), st.integers(-(2**31), 2**31 - 1)),
).map(list)
_absinfo = st.tuples(
    st.integers(-100, 100), st.integers(-100, 5000), st.just(0), st.just(0), st.integers(0, 50)
).map(list)
_device = st.fixed_dictionaries(
    {
        "evdev": st.fixed_dictionaries(
            {
                "name": st.text(max_size=8),
                "id": st.just([3, 1, 2, 3]),
                "codes": st.fixed_dictionaries(
                    {
                        1: st.lists(st.sampled_from([320, 325, 330, 272]), max_size=4),
                        3: st.lists(st.sampled_from([0, 1, 24, 47, 53, 54, 57, 58]), max_size=8),
                    }
                ),
                "absinfo": st.dictionaries(
                    st.sampled_from([0, 1, 24, 47, 53, 54, 57, 58]), _absinfo
                ),
                "properties": st.lists(st.integers(0, 5), max_size=3),
            }
        ),
        "events": st.lists(st.fixed_dictionaries({"evdev": st.lists(_event, max_size=8)})),
    }
)


@given(doc=st.one_of(_yaml_values, _device))
def test_random_libinput_record_never_crashes(
    tmp_path_factory: pytest.TempPathFactory, doc: object
) -> None:
    import yaml

    from stiction.drivers.evdev.playback import ReplaySource
    from stiction.errors import StictionError

    p = tmp_path_factory.mktemp("rnd") / "x.yml"
    p.write_text(yaml.safe_dump({"version": 1, "devices": [doc]}))
    try:
        rec = load(p)
    except RecordingError:
        return
    FrameAssembler(rec.description).feed_many(rec.events)
    try:
        src = ReplaySource(rec)  # the daemon's path: size checks, then samples
    except StictionError:
        return
    for smp in src.samples():
        assert smp.pressure is None or 0.0 <= smp.pressure <= 1.0


def test_multi_device_libinput_record_picks_the_touchpad(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    keyboard = textwrap.dedent(
        """\
          - node: /dev/input/event3
            evdev:
              name: "AT Translated Set 2 keyboard"
              id: [17, 1, 1, 43841]
              codes:
                0: [0, 1, 4]
                1: [1, 2, 3, 30, 31]
              absinfo: {}
              properties: []
            events:
              - evdev:
                - [  0,      0,   1,  30,     1]
                - [  0,      0,   0,   0,     0]
        """
    )
    keyboard = textwrap.indent(keyboard, "  ")  # a list item under devices:
    head, devices = HAND_YAML.split("devices:\n")
    p = tmp_path / "two.yml"
    p.write_text(head.replace("ndevices: 1", "ndevices: 2") + "devices:\n" + keyboard + devices)
    assert load(p).description.name == "Test Synaptics"
    assert load(p, device=0).description.name == "AT Translated Set 2 keyboard"
    with pytest.raises(RecordingError, match="no device 5"):
        load(p, device=5)
    assert main(["evdev", "decode", str(p), "--json", "--index", "1"]) == 0
    rows = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert [len(r["contacts"]) for r in rows] == [1, 1, 0]
