"""`stiction simulate` end to end: files in, files out, one-line errors."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from stiction.cli import main
from stiction.sim import ContactSim, Params, Touch


def write_trace(
    path: Path, rows: list[tuple[float, float, float, int]], pressure: bool = False
) -> None:
    with path.open("w") as f:
        f.write("t,x,y,contact" + (",pressure" if pressure else "") + "\n")
        for t, x, y, c in rows:
            f.write(f"{t!r},{x!r},{y!r},{c}" + (",0.8" if pressure else "") + "\n")


def stroke() -> list[tuple[float, float, float, int]]:
    rows = []
    for i in range(0, 241):
        t = i / 200
        c = 1 if 0.05 <= t <= 1.0 else 0
        rows.append((t, 0.02 + 0.03 * t, 0.03 + 0.002 * math.sin(6 * t), c))
    return rows


def read(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def test_simulate_writes_the_documented_columns_and_matches_contact_sim(tmp_path: Path) -> None:
    trace = tmp_path / "trace.csv"
    out = tmp_path / "out.csv"
    rows = stroke()
    write_trace(trace, rows)
    assert main(["simulate", str(trace), "--out", str(out)]) == 0
    got = read(out)
    assert list(got[0]) == [
        "t", "touch_x", "touch_y", "pointer_x", "pointer_y", "vx", "vy", "phase", "tension",
        "string_px",
    ]  # fmt: skip
    assert len(got) == 121  # ticks every 10 ms from 0.0 to 1.2 s inclusive
    assert {r["phase"] for r in got} == {"up", "stick", "slip"}
    # The same ticks by hand: ContactSim is the one the daemon runs.
    sim = ContactSim(Params())
    i = 0
    for k, r in enumerate(got):
        t = k * 0.01
        batch = []
        while i < len(rows) and rows[i][0] <= t + 1e-9:
            rt, x, y, c = rows[i]
            batch.append(Touch(min(rt, t), x, y, bool(c)))
            i += 1
        st = sim.advance(t, batch)
        assert float(r["pointer_x"]) == st.pointer_x
        assert r["phase"] == st.phase
        assert float(r["string_px"]) == st.string_px


def test_integrator_params_and_rate_are_applied(tmp_path: Path) -> None:
    trace = tmp_path / "trace.csv"
    write_trace(trace, stroke())
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["simulate", str(trace), "--out", str(a), "--param", "mu_s=5.0"]) == 0
    assert all(
        r["phase"] in ("stick", "up") for r in read(a)
    )  # stick radius 49 mm > 28.5 mm travel
    assert main(
        ["simulate", str(trace), "--out", str(b), "--integrator", "rk4", "--substeps", "4",
         "--rate", "240", "--param", "mu_s=0", "--events", "on"]
    ) == 0  # fmt: skip
    got = read(b)
    assert len(got) == 289 and "stick" not in {r["phase"] for r in got[20:200]}


def test_scene_material_string_and_pressure(tmp_path: Path) -> None:
    trace = tmp_path / "trace.csv"
    write_trace(trace, stroke(), pressure=True)
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[scene]\nname = "t"\neffects = ["stick_slip"]\noutside = "glue"\n\n'
        "[materials.glue]\nmu_s = 5.0\nmu_k = 0.1\n"
    )
    out = tmp_path / "o.csv"
    assert main(["simulate", str(trace), "--out", str(out), "--scene", str(scene)]) == 0
    got = read(out)
    assert all(r["phase"] in ("stick", "up") for r in got)  # mu_s = 5 from the scene
    assert all(float(r["string_px"]) == 0.0 for r in got)  # no "string" effect


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("", "empty trace"),
        ("a,b\n1,2\n", "header lacks t, x, y, contact"),
        ("t,x,y,contact\n", "no samples"),
        ("t,x,y,contact\n0,0,0,1\n0.01,zz,0,1\n", ":3: x is not a number"),
        ("t,x,y,contact\n0,0,0,1\n0.01,nan,0,1\n", ":3: x must be finite"),
        ("t,x,y,contact\n0,0,0,1\n0.01,0,0,2\n", ":3: contact must be 0 (not touching) or 1"),
        ("t,x,y,contact\n0.5,0,0,1\n0.1,0,0,1\n", ":3: time 0.1 goes back"),
        ("t,x,y,contact\n0,0\n", ":2: expected 4 columns"),
        ("t,x,y,contact\n\xff\xfe\n", "not a text CSV"),
        # finite but absurd: the tension overflowed and the output said inf
        ("t,x,y,contact\n0,1e308,0,1\n0.01,-1e308,0,1\n", ":2: x = 1e+308 m is off any tablet"),
        ("t,x,y,contact\n0,0,0,1\n0.01,0,-1001,1\n", ":3: y = -1001 m is off any tablet"),
    ],
)
def test_bad_traces_are_one_line_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str, message: str
) -> None:
    trace = tmp_path / "bad.csv"
    trace.write_bytes(content.encode("latin-1"))
    out = tmp_path / "out.csv"
    assert main(["simulate", str(trace), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists() and not (tmp_path / "out.csv.part").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--param", "k=-1"], "parameter k must be > 0"),
        (["--param", "kk=1"], "unknown parameter 'kk'"),
        (["--param", "k"], "--param wants NAME=VALUE"),
        (["--integrator", "verlet"], "unknown integrator"),
        (["--substeps", "0"], "substeps must be >= 1"),
        (["--substeps", "100000000"], "<= 10000"),  # ran for hours: a hang
        (["--rate", "0"], "parameter rate must be > 0"),
        (["--param", "k=1e4", "--integrator", "explicit-euler"], "use substeps >= 51"),
        (["--scene", "/nonexistent.toml"], "nonexistent.toml"),
    ],
)
def test_bad_options_are_one_line_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    trace = tmp_path / "trace.csv"
    write_trace(trace, stroke())
    assert main(["simulate", str(trace), "--out", str(tmp_path / "o.csv"), *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_missing_trace_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", str(tmp_path / "none.csv"), "--out", str(tmp_path / "o.csv")]) == 2
    assert "cannot read trace" in capsys.readouterr().err
