"""Running stiction as a normal user: udev rules, the doctor, the systemd user unit.

Nothing here is needed to read a device; it is what makes the devices
readable without root and says what is wrong when they are not.
"""
