"""Sensing."""

__all__ = ["catalog", "geometry", "identities", "image", "labels", "motion", "protocol",
           "synthetic"]
