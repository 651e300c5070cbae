"""Clients of stictiond: read its frames in Python, record and replay them,
and watch them in a browser.

    from stiction.clients import Subscriber
    with Subscriber("tcp://127.0.0.1:5556") as sub:
        for frame in sub.frames(count=100):
            print(frame.tick, [c.pointer_px for c in frame.contacts])

Only protocol.py, pyzmq and msgpack are needed; numpy is imported when the
column view (``Subscriber.collect``, ``ContactTable``) is used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from stiction.clients.aio import AsyncSubscriber
from stiction.clients.control import ControlUnavailable
from stiction.clients.curve import CurveKeys
from stiction.clients.messages import Contact, Frame, Message, SceneMessage, StringState
from stiction.clients.stream import SubscriberStats
from stiction.clients.subscriber import Subscriber

if TYPE_CHECKING:
    from stiction.clients.columns import ContactTable

__all__ = [
    "AsyncSubscriber",
    "Contact",
    "ContactTable",
    "ControlUnavailable",
    "CurveKeys",
    "Frame",
    "Message",
    "SceneMessage",
    "StringState",
    "Subscriber",
    "SubscriberStats",
]


def __getattr__(name: str) -> Any:
    # ContactTable needs numpy; import it only when someone asks for it.
    if name == "ContactTable":
        from stiction.clients.columns import ContactTable

        return ContactTable
    raise AttributeError(f"module 'stiction.clients' has no attribute {name!r}")
