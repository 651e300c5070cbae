"""A pen's sample as generated source: the arithmetic of units.py with the device's numbers in.

The live reader's loop (live_code.py) and its shape functions
(live_shape_code.py) both build the PenSample of the contact the reader's
cells describe; both take the statements from here, so the two cannot
part: units._sample_function's operations, in the same order, with the
device's bounds, resolutions and scales written in as literals.
"""

from __future__ import annotations

from evdev import ecodes

from stiction.drivers.evdev.frames import FrameAssembler
from stiction.drivers.evdev.live_mt_code import COLLECT, minus
from stiction.drivers.evdev.units import SurfaceUnits


def tip_expression(asm: FrameAssembler) -> str:
    """The contact's tip as an expression of the reader's cells: BTN_TOUCH where the
    device has it, else pressure above the assembler's threshold, else never."""
    if asm._has_touch_key:
        return "key_touch"
    if asm._has_pressure:
        return f"c{ecodes.ABS_PRESSURE} > {asm._pressure_min!r}"
    return "False"


def sample_code(
    units: SurfaceUnits,
    asm: FrameAssembler,
    indent: str,
    stamp: str = "made  # its frame's time once the read went well",
    tail: tuple[str, ...] = COLLECT,
) -> str:
    """Statements that append the PenSample of the contact the cells describe
    (`last_tool` its tool, `stamp` the frame time or its number in the read):
    units._sample_function's arithmetic, operation for operation, with the
    device's numbers written in; `tail` hands the sample on."""
    x, y = ecodes.ABS_X, ecodes.ABS_Y
    p, tx, ty = ecodes.ABS_PRESSURE, ecodes.ABS_TILT_X, ecodes.ABS_TILT_Y
    x0, x1, y0, y1 = units._bounds
    rx, ry = units._rx, units._ry
    xv = f"c{x}" if x in asm._abs else "0"
    yv = f"c{y}" if y in asm._abs else "0"
    tip = tip_expression(asm)
    lines = [
        "s = blank()",
        f"s.t = {stamp}",
        # `inside`: the position is on the surface, nothing to clamp (the common case)
        "if inside:",
        f"    s.x = {minus(xv, x0)} / {rx!r} / 1000",
        f"    s.y = {minus(yv, y0)} / {ry!r} / 1000",
        "else:",
    ]
    for name, value, lo, hi in (("xs", xv, x0, x1), ("ys", yv, y0, y1)):
        lines += [
            f"    {name} = {value}",
            f"    if {name} < {lo!r}:",
            f"        {name} = {lo!r}",
            f"    elif {name} > {hi!r}:",
            f"        {name} = {hi!r}",
        ]
    lines += [
        f"    s.x = {minus('xs', x0)} / {rx!r} / 1000",
        f"    s.y = {minus('ys', y0)} / {ry!r} / 1000",
        f"s.tip = {tip}",
        "s.in_range = True",
        "s.contact = 0",
    ]
    ps = units._pressure
    if asm._has_pressure and ps is not None:
        lines += [
            f"pf = {minus(f'c{p}', ps.offset)} * {ps.scale!r}",
            "s.pressure = 0.0 if pf < 0.0 else 1.0 if pf > 1.0 else pf",
        ]
    else:
        lines.append("s.pressure = None")
    lines.append("s.tool = last_tool")
    for axis, code, attr in ((units._tilt_x, tx, "tilt_x"), (units._tilt_y, ty, "tilt_y")):
        if asm._has_tilt and axis is not None:
            # clamped to the declared range's ends, as units.sample does
            t_lo, t_hi = axis.lo, axis.hi
            lines += [
                f"tv = {minus(f'c{code}', axis.offset)} * {axis.scale!r}",
                f"s.{attr} = {t_lo!r} if tv < {t_lo!r} else {t_hi!r} if tv > {t_hi!r} else tv",
            ]
        else:
            lines.append(f"s.{attr} = None")
    lines += [
        "s.buttons = buttons",
        "last_sample = s",
        *tail,
    ]
    return "".join(f"{indent}{line}\n" for line in lines)


def derived_fields(units: SurfaceUnits, asm: FrameAssembler) -> list[tuple[int, str, list[str]]]:
    """The sample's fields that follow from one axis alone: (code, field, statements
    that set `v` from the cell `c<code>`, units.sample's arithmetic with the
    clamping written in). A position is clamped to the surface and a tilt to
    its range; a value already inside is left as it is, so the statements give
    the same number as sample_code's (which skips the clamping while `inside`)."""
    x, y = ecodes.ABS_X, ecodes.ABS_Y
    p, tx, ty = ecodes.ABS_PRESSURE, ecodes.ABS_TILT_X, ecodes.ABS_TILT_Y
    x0, x1, y0, y1 = units._bounds
    out: list[tuple[int, str, list[str]]] = []
    for code, attr, lo, hi, r in ((x, "x", x0, x1, units._rx), (y, "y", y0, y1, units._ry)):
        if code in asm._abs:
            out.append(
                (
                    code,
                    attr,
                    [
                        f"v = c{code}",
                        f"if v < {lo!r}:",
                        f"    v = {lo!r}",
                        f"elif v > {hi!r}:",
                        f"    v = {hi!r}",
                        f"v = {minus('v', lo)} / {r!r} / 1000",
                    ],
                )
            )
    ps = units._pressure
    if asm._has_pressure and ps is not None:
        out.append(
            (
                p,
                "pressure",
                [
                    f"v = {minus(f'c{p}', ps.offset)} * {ps.scale!r}",
                    "v = 0.0 if v < 0.0 else 1.0 if v > 1.0 else v",
                ],
            )
        )
    for axis, code, attr in ((units._tilt_x, tx, "tilt_x"), (units._tilt_y, ty, "tilt_y")):
        if asm._has_tilt and axis is not None:
            t_lo, t_hi = axis.lo, axis.hi
            out.append(
                (
                    code,
                    attr,
                    [
                        f"v = {minus(f'c{code}', axis.offset)} * {axis.scale!r}",
                        f"v = {t_lo!r} if v < {t_lo!r} else {t_hi!r} if v > {t_hi!r} else v",
                    ],
                )
            )
    return out
