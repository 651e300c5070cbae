"""Differential tests: stiction's HID parser and decoders against hid-tools.

Two references, on every descriptor and every recorded report of
shared/data/hid: the `*.expected.json` oracle files (hid-tools 0.12 output
with its Push bug corrected), and hid-tools itself run live in this test.
Where hid-tools 0.12 is wrong -- Push loses Unit and Unit Exponent, the
fields each oracle lists in `push_fix_changed_fields` -- the live comparison
asserts that hid-tools shows exactly the documented wrong value and that
stiction matches the corrected oracle instead.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hidtools.hid import ReportDescriptor as HtDescriptor

from stiction.drivers.hid.decoder import ReportDecoder, field_values
from stiction.drivers.hid.descriptor import Field, ReportDescriptor, parse_descriptor
from stiction.drivers.hid.recording import Recording, load_recording

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "hid"
FILES = sorted(p.stem for p in DATA.glob("*.hid"))
FIELD_KEYS = (
    "usage",
    "bit_offset",
    "bit_size",
    "count",
    "logical_min",
    "logical_max",
    "physical_min",
    "physical_max",
    "unit",
    "unit_exponent",
)


def test_shared_data_present(hid_data: Path) -> None:
    assert len(FILES) >= 20, f"expected the shared HID recordings in {hid_data}"


def _load(name: str) -> tuple[Recording, ReportDescriptor, dict[str, Any]]:
    rec = load_recording(DATA / f"{name}.hid")
    oracle = json.loads((DATA / f"{name}.expected.json").read_text())
    return rec, parse_descriptor(rec.descriptor), oracle


def _expand(fields: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Undo the oracle's run-length compression (`repeat`) of identical consecutive fields."""
    out = []
    for f in fields:
        for i in range(f.get("repeat", 1)):
            g = dict(f)
            g["bit_offset"] = f["bit_offset"] + i * f["bit_size"] * f["count"]
            out.append(g)
    return out


@pytest.mark.parametrize("name", FILES)
def test_fields_match_oracle(name: str) -> None:
    rec, desc, oracle = _load(name)
    assert oracle["descriptor_length"] == len(rec.descriptor)
    for kind in ("input_reports", "output_reports", "feature_reports"):
        mine = getattr(desc, kind)
        assert sorted(mine) == sorted(r["report_id"] or 0 for r in oracle[kind]), kind
        for expected in oracle[kind]:
            report = mine[expected["report_id"] or 0]
            assert report.bit_size == expected["bit_size"], (kind, expected["report_id"])
            if "fields" not in expected:
                continue
            fields = _expand(expected["fields"])
            assert len(report.fields) == len(fields)
            for got, exp in zip(report.fields, fields, strict=True):
                for key in FIELD_KEYS:
                    assert getattr(got, key) == exp[key], (kind, expected["report_id"], key, exp)
                assert got.flags == exp["flags_raw"]
                if got.array:
                    assert list(got.usages) == exp.get("usages", [])


def _push_fixed(oracle: dict[str, Any]) -> dict[tuple[int, int], dict[str, Any]]:
    return {
        (c["report_id"] or 0, c["field_index"]): c
        for c in oracle["oracle"].get("push_fix_changed_fields", [])
        if c["report_type"] == "input"
    }


@pytest.mark.parametrize("name", FILES)
def test_fields_match_live_hidtools(name: str) -> None:
    rec, desc, oracle = _load(name)
    ht = HtDescriptor.from_bytes(list(rec.descriptor))
    fixed = _push_fixed(oracle)
    assert sorted(max(k, 0) for k in ht.input_reports) == sorted(desc.input_reports)
    for key, ht_report in ht.input_reports.items():
        report = desc.input_reports[max(key, 0)]
        ht_fields = list(ht_report)
        assert len(ht_fields) == len(report.fields)
        for i, (got, h) in enumerate(zip(report.fields, ht_fields, strict=True)):
            assert (got.usage, got.bit_offset, got.bit_size, got.count) == (
                h.usage,
                h.start,
                h.size,
                h.count,
            )
            assert (got.logical_min, got.logical_max) == (h.logical_min, h.logical_max)
            assert (got.physical_min, got.physical_max) == (h.physical_min, h.physical_max)
            bug = fixed.get((report.report_id, i))
            if bug is None:
                assert (got.unit, got.unit_exponent) == (h.unit, h.unit_exp)
            else:
                # hid-tools 0.12 loses these after Push; we follow the HID spec.
                assert (h.unit, h.unit_exp) == (
                    bug["unit_hidtools_raw"],
                    bug["unit_exponent_hidtools_raw"],
                )
                assert (got.unit, got.unit_exponent) == (
                    bug["unit_fixed"],
                    bug["unit_exponent_fixed"],
                )


def test_push_bug_is_exercised() -> None:
    """The live comparison above must actually meet the hid-tools Push bug somewhere."""
    hit = sum(len(_push_fixed(_load(n)[2])) for n in FILES)
    assert hit >= 4


def _named_values(
    report_fields: list[Field], oracle_fields: list[dict[str, Any]], data: bytes
) -> dict[str, Any]:
    """This report's values in the oracle's shape: {usage name: value or [values]}."""
    out: dict[str, list[Any]] = {}
    for f, o in zip(report_fields, oracle_fields, strict=True):
        if f.constant:
            continue
        vals = field_values(f, data)
        out.setdefault(o["usage_name"], []).append(vals if f.array else vals[0])
    return {k: v[0] if len(v) == 1 else v for k, v in out.items()}


RECORDED = [n for n in FILES if load_recording(DATA / f"{n}.hid").events] if DATA.is_dir() else []


@pytest.mark.parametrize("name", RECORDED)
def test_values_match_oracle_and_hidtools(name: str) -> None:
    rec, desc, oracle = _load(name)
    ht = HtDescriptor.from_bytes(list(rec.descriptor))
    decoders = {rid: ReportDecoder(r) for rid, r in desc.input_reports.items()}
    fields_by_id = {(r["report_id"] or 0): _expand(r["fields"]) for r in oracle["input_reports"]}
    assert len(oracle["events"]) == len(rec.events)
    checked = 0
    for ev, exp in zip(rec.events, oracle["events"], strict=True):
        assert ev.data.hex(" ") == exp["data"]
        rid = ev.data[0] if desc.numbered else 0
        report = desc.input_reports[rid]
        # 1. the slow reference reading against the oracle's values
        expected = {k: (v["raw"] if isinstance(v, dict) else v) for k, v in exp["values"].items()}
        assert _named_values(report.fields, fields_by_id[rid], ev.data) == expected
        # 2. the compiled decoder against hid-tools' field-by-field parsing, live
        ht_report = ht.input_reports[rid if desc.numbered else -1]
        ht_values = [v for f in ht_report if not f.is_const for v in f.get_values(list(ev.data))]
        assert list(decoders[rid].decode(ev.data)) == ht_values
        checked += 1
    assert checked == len(rec.events) > 0


@pytest.mark.parametrize("name", RECORDED)
def test_batch_decoding_equals_one_at_a_time(name: str) -> None:
    rec, desc, _ = _load(name)
    for rid, report in desc.input_reports.items():
        rows = [
            ev.data
            for ev in rec.events
            if (ev.data[0] if desc.numbered else 0) == rid and len(ev.data) >= report.byte_size
        ]
        if not rows:
            continue
        dec = ReportDecoder(report)
        width = max(len(r) for r in rows)
        arr = np.zeros((len(rows), width), dtype=np.uint8)
        for i, r in enumerate(rows):
            arr[i, : len(r)] = np.frombuffer(r, dtype=np.uint8)
        batch = dec.decode_batch(arr)
        assert batch.shape == (len(rows), len(dec.elements))
        for i, r in enumerate(rows):
            assert tuple(int(v) for v in batch[i]) == dec.decode(r.ljust(width, b"\0"))


def test_reports_array_handles_mixed_lengths() -> None:
    rec, desc, _ = _load("ugee-m708-v2")
    dec = ReportDecoder(desc.input_reports[7])
    rows = [ev.data for ev in rec.events[:50]]
    mixed = [r + b"\x00" * (i % 3) for i, r in enumerate(rows)]  # longer reports are valid
    same = dec.decode_batch(dec.reports_array(rows))
    assert (dec.decode_batch(dec.reports_array(mixed)) == same).all()
    assert [tuple(int(v) for v in row) for row in same] == [dec.decode(r) for r in rows]
