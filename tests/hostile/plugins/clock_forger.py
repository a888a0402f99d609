"""Replaces the timer with a frozen one, then takes 5 ms a frame: its runtime must still show."""

import time

import azgym


class ClockForger:
    def __init__(self):
        self.ransac = azgym.make_localizer("ransac")
        time.perf_counter_ns = lambda: 0

    def localize(self, measurements, beacons):
        time.sleep(0.005)
        return self.ransac.localize(measurements, beacons)
