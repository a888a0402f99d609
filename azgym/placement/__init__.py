"""Beacon-layout planning: predict a layout's accuracy over the floor, and place more beacons.

``floor`` the grid of cells a camera can stand on; ``visibility`` which beacons each cell sees
(the geometry sensor's rule); ``information`` each beacon's information about the pose and the
predicted σ (eq. 1-3); ``objective`` the figures of a σ map and the optimizer's score;
``monte_carlo`` the check through a localizer; ``analysis`` the ``analyze`` command's work;
``candidates`` and ``optimize`` the places for new beacons and the greedy search with swaps;
``scenario_file`` the new layout as a scenario file; ``surveyed`` a survey's map and
covariances; ``figures`` the heat maps.
See docs/layout.md.
"""

__all__ = ["analysis", "candidates", "figures", "floor", "information", "monte_carlo", "objective",
           "optimize", "scenario_file", "surveyed", "visibility"]
