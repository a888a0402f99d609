"""Ends its process with os._exit in localize (nothing to catch)."""

import os


class HardExiter:
    def localize(self, measurements, beacons):
        os._exit(4)
