"""scene package of stiction."""
