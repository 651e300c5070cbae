"""hid package of stiction."""
