"""Segfaults on frames with an even number of detections, else answers as ransac."""

import ctypes

import azgym


class Crasher:
    '''Segfaults on frames with an even number of detections, else answers as ransac.'''
    def __init__(self):
        self.ransac = azgym.make_localizer("ransac")

    def localize(self, measurements, beacons):
        if len(measurements) % 2 == 0:
            ctypes.string_at(0)
        return self.ransac.localize(measurements, beacons)
