"""The listed sizes of the suites are the frames they draw."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from azgym.bench.suites import SUITES
from azgym.bench.suites.sizes import FRAMES, frames

ENTRIES = Path(__file__).parents[2] / "leaderboard" / "entries"


@pytest.mark.parametrize("name", SUITES.names(plugins=False))
def test_each_suite_draws_the_frames_listed(name):
    suite = SUITES[name]
    quick, full = frames(name)
    assert len(suite.build(suite.dev_seed, True)) == quick
    reference = json.loads((ENTRIES / f"ransac-{name}.json").read_text())  # checked on build
    assert (reference["suite_version"], reference["quick"], reference["n_frames"]) == \
        (suite.version, False, full)


def test_every_built_in_suite_has_its_size_and_no_other():
    assert sorted(FRAMES) == sorted((name, SUITES[name].version)
                                    for name in SUITES.names(plugins=False))
