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

from typing import TYPE_CHECKING

from stiction.lazy import exports as _exports

if TYPE_CHECKING:
    from stiction.clients.aio import AsyncSubscriber
    from stiction.clients.columns import ContactTable
    from stiction.clients.control import ControlUnavailable
    from stiction.clients.curve import CurveKeys
    from stiction.clients.messages import Contact, Frame, Message, SceneMessage, StringState
    from stiction.clients.stream import SubscriberStats
    from stiction.clients.subscriber import Subscriber

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

# The names above are imported on first use (PEP 562), not with the package:
# they need pyzmq and msgpack, AsyncSubscriber asyncio, ContactTable numpy, and
# `stiction --help` imports stiction.clients.cli and so this package. Type
# checkers read the TYPE_CHECKING imports instead.
_SOURCES = {
    "AsyncSubscriber": "stiction.clients.aio",
    "ContactTable": "stiction.clients.columns",
    "ControlUnavailable": "stiction.clients.control",
    "CurveKeys": "stiction.clients.curve",
    "Contact": "stiction.clients.messages",
    "Frame": "stiction.clients.messages",
    "Message": "stiction.clients.messages",
    "SceneMessage": "stiction.clients.messages",
    "StringState": "stiction.clients.messages",
    "SubscriberStats": "stiction.clients.stream",
    "Subscriber": "stiction.clients.subscriber",
}


_lazy, __dir__ = _exports(__name__, _SOURCES, globals(), __all__)

if not TYPE_CHECKING:
    # Hidden from type checkers: a visible module __getattr__ would make them
    # accept any misspelt name imported from this package.
    __getattr__ = _lazy
