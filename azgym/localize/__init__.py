"""Localizers: the interface, the registry and the built-in algorithms."""
