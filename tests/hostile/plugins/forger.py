"""Hangs, while a thread keeps telling the runner that a new call just began."""

import sys
import threading
import time


class Forger:
    '''Hangs, while a thread keeps telling the runner that a new call just began.'''
    def localize(self, measurements, beacons):
        frame = sys._getframe()
        while "progress" not in frame.f_locals:
            frame = frame.f_back
        progress = frame.f_locals["progress"]

        def forge():
            while True:
                progress[1] = time.monotonic_ns()
                time.sleep(0.01)

        threading.Thread(target=forge, daemon=True).start()
        time.sleep(3600)
