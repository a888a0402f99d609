"""Calls sys.exit in localize."""

import sys


class Exiter:
    def localize(self, measurements, beacons):
        sys.exit(3)
