"""Navigation suites: navigators driven in closed loop, scored, reported and put on the board.

``suites`` the closed-loop suites and navigators by name; ``scoring`` a drive of an environment
with a policy and its scores (success, SPL, collisions, the localization error along the way);
``benchmark`` every (navigator, localizer) pair of a suite; ``report`` their table and figure;
``results_file`` their results files, checked as an adversary's; ``board`` rerun and shown on
the leaderboard. The environments are :mod:`azgym.envs`, the policies' files
:mod:`azgym.nav.policy_file`.
"""

from azgym.bench.navigation.suites import (
    NAVIGATION_SUITES,
    NAVIGATORS,
    NavigationSuite,
    get_navigation_suite,
)

__all__ = ["NAVIGATION_SUITES", "NAVIGATORS", "NavigationSuite", "get_navigation_suite"]
