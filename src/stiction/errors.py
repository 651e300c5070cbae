"""The one exception family for mistakes a user can make.

Anything that is the user's (or a device's) fault -- a bad parameter, a
malformed descriptor, a scene file with a typo -- raises a subclass of
`StictionError`. Command-line entry points catch exactly this family and print
its message without a traceback; anything else escaping is a bug in stiction
and is allowed to show its traceback.
"""

from __future__ import annotations


class StictionError(Exception):
    """A problem with input, configuration or a device, explained in words."""


class ParamError(StictionError, ValueError):
    """A model parameter or integrator setting that cannot be used."""


class DeviceError(StictionError):
    """A device that cannot be opened, read or understood."""


class SizeUnknown(DeviceError):
    """A device whose coordinates cannot become metres until its user gives its size.

    The driver knows what is missing; only the command knows how its user
    gives a size (a flag, a config key), so each command re-raises it with
    `told(how)`: every such error names the flag or key of the command that
    printed it. Sizes are typed in millimetres everywhere, with the unit in
    the name (`size_mm`, `--size-mm`).
    """

    def __init__(self, what: str, how: str = "see docs/devices.md") -> None:
        self.what = what
        self.how = how
        super().__init__(f"{what}; give its active area in millimetres: {how}")

    def told(self, how: str) -> SizeUnknown:
        return SizeUnknown(self.what, how)


class DescriptorError(DeviceError):
    """A HID report descriptor that cannot be parsed."""


class RecordingError(StictionError):
    """A recording file (hid-recorder, evemu, libinput record, trace CSV) that is malformed."""


class SceneError(StictionError):
    """A scene file that is malformed; the message names file, line and field."""


class ProtocolError(StictionError):
    """A wire message that does not follow docs/protocol.md."""
