"""daemon package of stiction."""
