"""Scripted pen movements in surface metres, sampled like a tablet (200 Hz).

A script is a list of segments; each moves the pen between two points with
a minimum-jerk profile (the smooth bell-shaped speed of a human reaching
movement), so stick-slip transitions look as they would with a hand.

- ``stroke``: the paper's task. The pen comes into range, touches down near
  the centre, stays still briefly, drags 25 mm to the right at about
  40 mm/s (past the 9.8 mm stick travel at mu_s = 1, leaving ~70 px of
  pointer travel on a typical mapping), stays, lifts and leaves.
- ``circles``: three circles of 20 mm radius at one turn per second.
- ``demo``: horizontal passes across the whole surface at four heights, each
  with a pause and a short reversal midway, lifting between passes, so a
  scene with sticky and slippery bands is crossed everywhere.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

RATE_HZ = 200.0
DT = 1.0 / RATE_HZ


@dataclass(frozen=True, slots=True)
class PenState:
    t: float
    x: float
    y: float
    tip: bool
    in_range: bool
    pressure: float
    tilt_x: float = 0.0
    tilt_y: float = 0.0


@dataclass(frozen=True, slots=True)
class Segment:
    duration: float
    start: tuple[float, float]
    end: tuple[float, float]
    tip: bool
    in_range: bool = True
    path: Callable[[float], tuple[float, float]] | None = None  # overrides start->end


def _min_jerk(s: float) -> float:
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def render(segments: list[Segment], t0: float = 0.0) -> list[PenState]:
    """Sample the segments every 5 ms; pressure rises and falls with contact."""
    out: list[PenState] = []
    k = 0  # sample index: times are t0 + k * DT, with no accumulated rounding
    for seg in segments:
        n = max(1, round(seg.duration * RATE_HZ))
        for i in range(n):
            t = t0 + k * DT
            k += 1
            s = i / n
            if seg.path is not None:
                x, y = seg.path(s)
            else:
                e = _min_jerk(s)
                x = seg.start[0] + (seg.end[0] - seg.start[0]) * e
                y = seg.start[1] + (seg.end[1] - seg.start[1]) * e
            pressure = 0.35 + 0.1 * math.sin(2.0 * math.pi * 1.3 * t) if seg.tip else 0.0
            tilt = 20.0 + 5.0 * math.sin(2.0 * math.pi * 0.4 * t)
            out.append(PenState(t, x, y, seg.tip, seg.in_range, pressure, tilt, -tilt / 2))
    return out


def _stroke(w: float, h: float) -> list[Segment]:
    start = (0.5 * w - 0.0125, 0.5 * h)
    end = (start[0] + 0.025, start[1])
    near = (start[0] - 0.004, start[1] + 0.003)
    away = (end[0] + 0.002, end[1] + 0.002)
    return [
        Segment(0.15, near, start, tip=False),
        Segment(0.4, start, start, tip=True),
        Segment(0.8, start, end, tip=True),
        Segment(0.3, end, end, tip=True),
        Segment(0.15, end, away, tip=False),
        Segment(0.01, away, away, tip=False, in_range=False),
        Segment(0.3, away, away, tip=False, in_range=False),
    ]


def _circles(w: float, h: float) -> list[Segment]:
    cx, cy, r = 0.5 * w, 0.5 * h, min(0.02, 0.2 * min(w, h))
    turns = 3.0

    def path(s: float) -> tuple[float, float]:
        a = 2.0 * math.pi * turns * s
        return cx + r * math.cos(a), cy + r * math.sin(a)

    p0 = (cx + r, cy)
    return [
        Segment(0.1, (p0[0] + 0.003, p0[1]), p0, tip=False),
        Segment(0.3, p0, p0, tip=True),
        Segment(turns, p0, p0, tip=True, path=path),
        Segment(0.2, p0, p0, tip=True),
        Segment(0.01, p0, p0, tip=False, in_range=False),
        Segment(0.3, p0, p0, tip=False, in_range=False),
    ]


def _demo(w: float, h: float) -> list[Segment]:
    segs: list[Segment] = []
    left, right = 0.06 * w, 0.94 * w
    span = right - left
    speed = 0.06  # m/s across the surface
    for k, frac in enumerate((0.2, 0.4, 0.6, 0.8)):
        y = frac * h
        a, b = (left, right) if k % 2 == 0 else (right, left)
        sign = 1.0 if b > a else -1.0
        mid = a + sign * 0.55 * span
        back = mid - sign * 0.12 * span
        hover_from = segs[-1].end if segs else (a, y)
        segs.append(Segment(0.4, hover_from, (a, y), tip=False))
        segs.append(Segment(0.3, (a, y), (a, y), tip=True))
        segs.append(Segment(abs(mid - a) / speed, (a, y), (mid, y), tip=True))
        segs.append(Segment(0.5, (mid, y), (mid, y), tip=True))
        segs.append(Segment(abs(mid - back) / speed * 1.5, (mid, y), (back, y), tip=True))
        segs.append(Segment(0.4, (back, y), (back, y), tip=True))
        segs.append(Segment(abs(b - back) / speed, (back, y), (b, y), tip=True))
        segs.append(Segment(0.3, (b, y), (b, y), tip=True))
    last = segs[-1].end
    segs.append(Segment(0.2, last, last, tip=False))
    segs.append(Segment(0.01, last, last, tip=False, in_range=False))
    segs.append(Segment(0.5, last, last, tip=False, in_range=False))
    return segs


SCRIPTS: dict[str, Callable[[float, float], list[Segment]]] = {
    "stroke": _stroke,
    "circles": _circles,
    "demo": _demo,
}
