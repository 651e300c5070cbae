"""evdev package of stiction."""
