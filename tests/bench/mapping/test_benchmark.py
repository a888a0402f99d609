"""The mapping runner end to end on the quick suite: the built-ins isolated, scored, repeated."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from azgym.bench.mapping.benchmark import run_mapping
from azgym.bench.mapping.suites import get_mapping_suite
from azgym.errors import InvalidInputError

pytestmark = pytest.mark.slow

MAPPERS = ["prior", "rays", "survey"]


@pytest.fixture(scope="module")
def result():
    return run_mapping("mapping", MAPPERS, quick=True, workers=2, time_limit=60.0)


def figures(result):
    """Everything a run scores, the seconds it took left out."""
    return {spec: [dataclasses.replace(case, runtime=None) for case in cases]
            for spec, cases in result.scores.items()}, {
        spec: dataclasses.replace(summary, runtime_median_s=0.0)
        for spec, summary in result.summaries.items()}


def test_every_mapper_is_scored_on_every_case(result):
    assert result.mappers == tuple(MAPPERS) and result.split == "dev" and result.quick
    assert list(result.scores) == MAPPERS
    for spec in MAPPERS:
        cases = result.scores[spec]
        assert [c.case for c in cases] == list(result.cases)
        assert [c.failure for c in cases] == [None] * 4
        assert all(c.runtime is not None and c.runtime >= 0.0 for c in cases)
        assert result.summaries[spec].cases == 4 and result.summaries[spec].failures == 0
    # ransac on the true maps is the same whoever mapped
    assert len({tuple(c.localization_true for c in result.scores[s]) for s in MAPPERS}) == 1


def test_the_prior_places_nothing_and_is_charged_for_what_it_lacks(result):
    unknown, moved, _, unchanged = result.scores["prior"]
    assert result.summaries["prior"].placed_percent == 0.0
    assert all(c.said_moved == () for c in result.scores["prior"])
    # the map unknown but two anchors: every other observable beacon has no position
    assert unknown.beacons and all(b.error == math.inf for b in unknown.beacons)
    # a stale map: a moved beacon's error is how far it moved; the others' none
    assert {b.beacon for b in moved.beacons if b.error > 0} == {m.beacon for m in moved.moved}
    assert all(m.delay is None and not m.said for m in moved.moved)
    assert all(b.error == 0.0 for b in unchanged.beacons)
    assert unchanged.localization_updated == unchanged.localization_true


def test_a_survey_from_the_true_start_and_two_anchors_places_the_beacons(result):
    unknown = result.scores["survey"][0]
    errors = np.array([b.error for b in unknown.beacons])
    assert np.all([b.placed for b in unknown.beacons])
    assert float(np.median(errors)) < 0.05


def test_the_same_seed_gives_the_same_figures_bit_for_bit_whatever_the_workers(result):
    again = run_mapping("mapping", MAPPERS, quick=True, workers=1, time_limit=60.0)
    assert repr(figures(again)) == repr(figures(result))


def test_a_run_is_refused_by_name_before_any_case_is_drawn():
    with pytest.raises(InvalidInputError, match="at least one mapper"):
        run_mapping("mapping", [])
    with pytest.raises(InvalidInputError, match="workers"):
        run_mapping("mapping", ["prior"], workers=0)
    with pytest.raises(InvalidInputError, match="time_limit"):
        run_mapping("mapping", ["prior"], time_limit=-1.0)
    assert get_mapping_suite("mapping").dev_seed == 2900
