"""Localizers: the interface, the registry and the built-in algorithms."""

from azgym.localize._cache import drop_stale_cache

drop_stale_cache()
