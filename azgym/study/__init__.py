"""Studies of azgym's models against what they model (``azgym study ...``)."""
