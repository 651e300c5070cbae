"""clients package of stiction."""
