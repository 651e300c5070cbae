"""stiction: a Linux input bridge for pseudo-haptics.

Pen tablets and touchpads in, a stick-slip friction simulation at a fixed
rate, pointer and virtual-string state out over ZeroMQ.
"""

__version__ = "0.1.0"
