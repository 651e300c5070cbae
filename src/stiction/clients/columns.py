"""Frames as numpy columns: one row per contact per frame.

Analysis (release times, string lengths, trajectories) is column arithmetic,
so frames are flattened into a long table rather than kept as nested maps.
Frames with no contact still count: the frame table keeps one row per frame,
and ``contact_frame`` links each contact row to its frame row.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, fields

import numpy as np
import numpy.typing as npt

from stiction.clients.messages import Frame

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
Str = npt.NDArray[np.str_]


@dataclass(frozen=True)
class ContactTable:
    """Frame columns (``frame_*``, one row per frame) and contact columns (one
    row per contact). Missing values are NaN: ``t_input`` before any input,
    ``string_px`` / ``string_dir`` when the scene draws no string."""

    frame_tick: I64
    frame_t: F64
    frame_t_input: F64
    frame_device: Str
    contact_frame: I64
    tick: I64
    t: F64
    device: Str
    id: I64
    phase: Str
    touch_m: F64
    pointer_m: F64
    touch_px: F64
    pointer_px: F64
    tension: F64
    material: Str
    string_px: F64
    string_dir: F64

    @classmethod
    def from_frames(cls, frames: Iterable[Frame]) -> ContactTable:
        ftick: list[int] = []
        ft: list[float] = []
        ftin: list[float] = []
        fdev: list[str] = []
        cframe: list[int] = []
        cid: list[int] = []
        phase: list[str] = []
        vecs: list[tuple[float, float, float, float, float, float, float, float]] = []
        tension: list[float] = []
        material: list[str] = []
        string: list[tuple[float, float, float]] = []
        nan = float("nan")
        for i, f in enumerate(frames):
            ftick.append(f.tick)
            ft.append(f.t)
            ftin.append(nan if f.t_input is None else f.t_input)
            fdev.append(f.device)
            for c in f.contacts:
                cframe.append(i)
                cid.append(c.id)
                phase.append(c.phase)
                vecs.append((*c.touch_m, *c.pointer_m, *c.touch_px, *c.pointer_px))
                tension.append(c.tension)
                material.append(c.material)
                s = c.string
                string.append((nan, nan, nan) if s is None else (s.length_px, *s.dir))
        frame_tick = np.asarray(ftick, dtype=np.int64)
        frame_t = np.asarray(ft, dtype=np.float64)
        frame_device = np.asarray(fdev, dtype=np.str_)
        contact_frame = np.asarray(cframe, dtype=np.int64)
        v = np.asarray(vecs, dtype=np.float64).reshape(-1, 8)
        s_arr = np.asarray(string, dtype=np.float64).reshape(-1, 3)
        return cls(
            frame_tick=frame_tick,
            frame_t=frame_t,
            frame_t_input=np.asarray(ftin, dtype=np.float64),
            frame_device=frame_device,
            contact_frame=contact_frame,
            tick=frame_tick[contact_frame],
            t=frame_t[contact_frame],
            device=frame_device[contact_frame] if len(fdev) else np.asarray([], dtype=np.str_),
            id=np.asarray(cid, dtype=np.int64),
            phase=np.asarray(phase, dtype=np.str_),
            touch_m=v[:, 0:2].copy(),
            pointer_m=v[:, 2:4].copy(),
            touch_px=v[:, 4:6].copy(),
            pointer_px=v[:, 6:8].copy(),
            tension=np.asarray(tension, dtype=np.float64),
            material=np.asarray(material, dtype=np.str_),
            string_px=s_arr[:, 0].copy(),
            string_dir=s_arr[:, 1:3].copy(),
        )

    def __len__(self) -> int:
        """Contact rows."""
        return int(self.id.shape[0])

    @property
    def frame_count(self) -> int:
        return int(self.frame_tick.shape[0])

    def as_dict(self) -> dict[str, np.ndarray]:
        """Column name -> array, e.g. for ``np.savez`` or ``pandas.DataFrame``."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
