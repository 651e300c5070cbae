"""Any user overlay: either entries the HID path can use, or one DeviceError.

The catalogue's user file is input a person types (issue 12: every
user-supplied input, the device catalogue overlay included, goes through one
error type). Random text rarely gets past the TOML parser, so this feeds the
entry validator structures built from the schema's own keys with values of
every type, then pushes whatever it accepts through the whole HID path
(merge, the HID view, a ReportStream on a real descriptor).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stiction.drivers.catalogue.load import parse_entries
from stiction.drivers.catalogue.resolve import merge
from stiction.drivers.catalogue.schema import EFFECT_KEYS
from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import from_resolved
from stiction.drivers.hid.families import FAMILIES
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.errors import DeviceError

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "hid"
OWN = load_recording(DATA / "veikk-s640.hid").descriptor  # a real pen descriptor

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["", "x", "0x10", "256c:006d", "ff", "huion-string-descriptor",
                     "feature:0203", "output:zz", "uclogic-v1", *FAMILIES]),
    st.text(max_size=12),
)  # fmt: skip
values = st.recursive(
    scalars,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=4), inner, max_size=3)
    ),
    max_leaves=8,
)
keys = st.sampled_from(sorted(EFFECT_KEYS | {"id", "name", "source", "match", "strings"}))
wild = st.dictionaries(keys, values, max_size=8)

# Mostly valid entries, so that most of them reach the HID path: each effect
# key with a plausible value (sizes of any magnitude, ranges that do not fit
# the sizes, descriptors of random bytes, any family, any fix-up).
pair = st.lists(st.floats(1e-6, 1e6) | st.integers(1, 10**7), min_size=2, max_size=2)
hexes = st.binary(max_size=40).map(bytes.hex)
plausible = {
    "size_mm": pair,
    "resolution_mm": pair,
    "max_x": st.integers(1, 2**31),
    "max_y": st.integers(1, 2**31),
    "max_pressure": st.integers(1, 2**16),
    "family": st.sampled_from(sorted(FAMILIES)),
    "init": st.sampled_from(["huion-string-descriptor", "feature:0203", "output:0202"]),
    "feature_init": st.lists(hexes, max_size=2),
    "output_init": st.lists(hexes, max_size=2),
    "init_strings": st.lists(st.integers(0, 255), max_size=2),
    "report_fixup": st.sampled_from(["uclogic-v1", "uclogic-v2"]),
    "report_length": st.integers(1, 64),
    "pen_reports": st.lists(st.integers(0, 255), max_size=3),
    "descriptor": st.sampled_from([OWN.hex()]) | hexes,
    "usage_aliases": st.dictionaries(
        st.sampled_from(["0x00090001", "0x000d0042"]),
        st.sampled_from(["0x000d0042", "0x000d0044", "0x00010030"]),
        max_size=2,
    ),
}
effects = st.fixed_dictionaries({}, optional=plausible)
ids = st.sampled_from(["2feb:0001", "256c:006d", "28bd:0096", "056a:0061"])
valid = st.tuples(ids, effects).map(lambda t: {"id": t[0], "name": "pad", "source": "test", **t[1]})
entry = st.one_of(valid, valid, valid, wild)


@settings(max_examples=400, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(devices=st.lists(entry, max_size=2))
def test_any_overlay_is_usable_entries_or_one_device_error(
    devices: list[dict[str, object]],
) -> None:
    try:
        entries = parse_entries(devices, "overlay.toml", "user")
    except DeviceError as exc:
        assert str(exc) and "\n" not in str(exc).strip()
        return
    for e in entries:
        r = merge(entries, e.match.vid, e.match.pid)
        if r is None:
            continue  # equally specific entries: none is used, by design
        try:
            hid = from_resolved(r, OWN)
            ReportStream(parse_descriptor(hid.descriptor or OWN), "pen", None, hid)
        except DeviceError:
            pass


def test_an_overlay_that_is_a_fifo_binary_or_a_folder_is_one_device_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A FIFO blocked every device lookup; a binary file was a UnicodeDecodeError."""
    import os

    from stiction.drivers.catalogue.load import USER_TABLE_ENV, user

    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xbc\xff\x00[[")
    for path, words in ((fifo, "not a regular file"), (tmp_path, "not a regular file"),
                        (binary, "not valid TOML")):  # fmt: skip
        monkeypatch.setenv(USER_TABLE_ENV, str(path))
        with pytest.raises(DeviceError, match=words):
            user()
    monkeypatch.setenv(USER_TABLE_ENV, str(tmp_path / "none.toml"))
    assert user() == ()
