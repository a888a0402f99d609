"""Raises MemoryError in localize."""

class Hoarder:
    def localize(self, measurements, beacons):
        raise MemoryError("asked for 1 TB")
