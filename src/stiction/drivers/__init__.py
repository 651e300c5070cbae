"""Device drivers: bytes and kernel events in, `PenSample`s in surface metres out.

Drivers know nothing of ZeroMQ, scenes or the simulator.
"""

from stiction.drivers.sample import PenSample, Tool

__all__ = ["PenSample", "Tool"]
