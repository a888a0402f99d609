"""Tries to corrupt what the other contenders are given, then answers as ransac."""

import azgym


class Scribbler:
    '''Tries to corrupt what the other contenders are given, then answers as ransac.'''
    def __init__(self):
        self.ransac = azgym.make_localizer("ransac")
        self.refused = 0

    def localize(self, measurements, beacons):
        try:
            measurements.azimuth.setflags(write=True)
            measurements.azimuth[:] += 1.0
        except ValueError:
            self.refused += 1
        beacons.xyz.setflags(write=True)
        beacons.xyz[:] += 5.0
        return self.ransac.localize(measurements, beacons)
