"""fake package of stiction."""
