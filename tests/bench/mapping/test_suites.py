"""The mapping suite's cases: what a mapper gets, what the runner keeps, drawn from the seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.bench.mapping.scoring import observable_by_truth, truly_moved
from azgym.bench.mapping.suites import PERTURBATIONS, get_mapping_suite
from azgym.errors import InvalidInputError, UnknownNameError

SUITE = get_mapping_suite("mapping")


@pytest.fixture(scope="module")
def quick():
    return SUITE.build(SUITE.dev_seed, True)


def test_the_quick_suite_is_one_route_under_each_perturbation(quick):
    assert [c.perturbation for c in quick] == list(PERTURBATIONS)
    assert {(c.scenario, c.route) for c in quick} == {("warehouse-small", "aisle-loop")}
    assert [c.name for c in quick] == [f"warehouse-small/aisle-loop/{p}" for p in PERTURBATIONS]


def test_a_drive_starts_from_the_true_camera_pose_and_carries_no_truth(quick):
    for case in quick:
        assert case.drive.start == tuple(case.truth.poses[0])
        assert len(case.drive.frames) == len(case.truth.poses)
        frame = case.drive.frames[0]
        assert set(vars(frame)) == {"time", "measurements", "motion"}


def test_each_perturbation_gives_its_prior(quick):
    unknown, moved, rack, unchanged = quick
    observable = observable_by_truth(unknown.truth.frames, unknown.truth.ids,
                                     unknown.truth.azimuths, unknown.truth.poses)
    # unknown: two anchors the drive observes, at their true positions, and nothing else
    assert len(unknown.prior.anchors) == 2 and set(unknown.prior.anchors) <= observable
    assert unknown.prior.beacons.ids.tolist() == sorted(unknown.prior.anchors)
    true = dict(zip(unknown.truth.beacons.ids.tolist(), unknown.truth.beacons.xyz.tolist(),
                    strict=True))
    assert all(true[i] == xyz for i, xyz in zip(unknown.prior.beacons.ids.tolist(),
                                                unknown.prior.beacons.xyz.tolist(), strict=True))
    # moved: 1-3 observable beacons moved, beside the one warehouse-small ships moved
    shipped = {9}
    perturbed = truly_moved(moved.prior.beacons, (), moved.truth.beacons) - shipped
    assert 1 <= len(perturbed) <= 3 and perturbed <= observable
    assert truly_moved(rack.prior.beacons, (), rack.truth.beacons) - shipped
    # unchanged: the prior is the truth, so nothing truly moved
    assert truly_moved(unchanged.prior.beacons, (), unchanged.truth.beacons) == frozenset()
    assert unchanged.truth.beacons.xyz.tobytes() == unchanged.prior.beacons.xyz.tobytes()


def test_the_drive_under_a_perturbation_is_the_same_drive_through_another_world(quick):
    unknown, moved, rack, _ = quick
    for other in (moved, rack):  # the route and the noise are the seed's; the beacons moved
        assert other.truth.poses.tobytes() == unknown.truth.poses.tobytes()
    changed = truly_moved(moved.prior.beacons, (), moved.truth.beacons) - {9}
    seen_moved = set(moved.truth.ids.tolist()) & changed
    assert seen_moved  # the moved beacons are seen where they now are
    rows = np.isin(moved.truth.ids, list(seen_moved))
    assert not math.isclose(float(np.sum(moved.truth.azimuths[rows])),
                            float(np.sum(unknown.truth.azimuths[np.isin(unknown.truth.ids,
                                                                        list(seen_moved))])))


def test_the_suite_is_its_seed_and_only_its_seed():
    first = SUITE.build(SUITE.dev_seed, True)
    again = SUITE.build(SUITE.dev_seed, True)
    other = SUITE.build(SUITE.dev_seed + 1, True)

    def figures(cases):
        return [(c.prior.anchors, c.truth.beacons.xyz.tobytes(), c.truth.poses.tobytes(),
                 b"".join(f.measurements.azimuth.tobytes() for f in c.drive.frames))
                for c in cases]

    assert figures(first) == figures(again)
    assert figures(first) != figures(other)


def test_the_suite_has_a_dev_split_only_and_a_name_checked():
    SUITE.check_split("dev")
    with pytest.raises(InvalidInputError, match="mapping has no test split"):
        SUITE.check_split("test")
    with pytest.raises(UnknownNameError, match="mapping"):
        get_mapping_suite("maping")
