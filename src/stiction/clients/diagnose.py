"""Why a subscriber hears nothing: no daemon, a daemon with no device yet, or the wrong endpoint.

A daemon with no device publishes no frames, so silence alone cannot tell a
user whether to start stictiond, plug in the tablet or fix an endpoint. The
control endpoint can: one bounded `devices` request, whose answer (or its
absence) names the case. `stiction listen` and `stiction web` say it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

from stiction.clients.control import ControlUnavailable, request, request_async
from stiction.clients.curve import CurveKeys
from stiction.errors import StictionError

Silence = Literal["no-daemon", "no-device", "ended", "elsewhere", "unknown"]


def explain(
    pub: str,
    control: str | None,
    reply: dict[str, Any] | None,
    error: StictionError | None,
    wanted: Sequence[str] | None = None,
) -> tuple[Silence, str]:
    """The case and one line for a user, from the `devices` reply or the request's error.

    `wanted`: the devices the subscriber filters on (--device); a name the
    daemon does not have explains the silence better than any endpoint does.
    """
    if control is None:
        return "unknown", f"no frames from {pub}; is stictiond running? (no control endpoint)"
    if isinstance(error, ControlUnavailable) or (reply is None and error is None):
        return "no-daemon", f"no daemon answers at {control}: is stictiond running?"
    if error is not None or reply is None:
        return "unknown", f"the daemon at {control} refused the devices request: {error}"
    devices = [d for d in reply.get("devices", []) if isinstance(d, dict)]
    live = [d for d in devices if d.get("state") == "open"]
    daemon = f"the daemon at {control} is up"
    if not devices:
        return "no-device", f"{daemon} but reads no device"
    names = [str(d.get("name")) for d in devices]
    if wanted and not set(wanted) & set(names):
        return "elsewhere", (
            f"{daemon} but has no device {', '.join(map(repr, wanted))} "
            f"(--device takes one of: {', '.join(names)})"
        )
    listed = ", ".join(f"{d.get('spec')} ({d.get('state')})" for d in devices)
    if all(d.get("state") == "ended" for d in devices):
        return "ended", f"{daemon} but its devices have ended: {listed}"
    if not live:
        return "no-device", f"{daemon} but has no device yet: waiting for {listed}"
    return "elsewhere", (
        f"{daemon} with {len(live)} device(s) open, but nothing arrives on {pub}: "
        "is that its --pub endpoint?"
    )


def why_silent(
    pub: str,
    control: str | None,
    *,
    curve: CurveKeys | None = None,
    timeout: float = 0.5,
    wanted: Sequence[str] | None = None,
) -> tuple[Silence, str]:
    if control is None:
        return explain(pub, None, None, None)
    try:
        reply = request(control, "devices", timeout=timeout, curve=curve)
    except StictionError as exc:
        return explain(pub, control, None, exc)
    return explain(pub, control, reply, None, wanted)


async def why_silent_async(
    pub: str, control: str | None, *, curve: CurveKeys | None = None, timeout: float = 0.5
) -> tuple[Silence, str]:
    if control is None:
        return explain(pub, None, None, None)
    try:
        reply = await request_async(control, "devices", timeout=timeout, curve=curve)
    except StictionError as exc:
        return explain(pub, control, None, exc)
    return explain(pub, control, reply, None)
