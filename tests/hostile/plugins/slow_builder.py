"""Sleeps forever in its constructor."""

import time


class SlowBuilder:
    def __init__(self):
        time.sleep(3600)

    def localize(self, measurements, beacons):
        raise AssertionError("never built")
