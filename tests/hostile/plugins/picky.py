"""ransac that answers only the frames it is sure of: the attack on a ranking of answered frames."""

import azgym


class Picky:
    '''Refuses every frame on which ransac finds fewer than ``min_inliers`` inliers.'''

    def __init__(self, min_inliers: int = 8):
        self.min_inliers = min_inliers
        self.ransac = azgym.make_localizer("ransac")

    def localize(self, measurements, beacons):
        estimate = self.ransac.localize(measurements, beacons)
        if estimate.ok and int(estimate.inliers.sum()) < self.min_inliers:
            return azgym.Estimate.failure("too few inliers to be sure", len(measurements))
        return estimate
