"""Misread ids in the survey: with a prior map only its ids are surveyed; without, few or
scattered detections of an id leave it unobservable."""

from __future__ import annotations

import numpy as np
import pytest

from azgym.core import BeaconMap, Measurements
from azgym.mapping import Drive, Prior, SurveyFrame, survey
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples

pytest.importorskip("gtsam")

RATE = 10.0
SAMPLES = 5
BEACONS = np.array([[5.0, 3.0], [2.0, -4.0], [9.0, 2.5]])
PHANTOM = np.array([4.0, 5.0])
"""Where a misread id's detections point from every frame: rays that meet, as a beacon's do."""


def drive(extra: dict[int, list[float]]) -> Drive:
    """A camera driving east along y = 0 at 1 m/s for 10 s, seeing beacons 1-3 exactly.

    ``extra`` maps a misread id to its azimuth per frame (NaN: not seen in that frame).
    """
    frames = []
    for k in range(int(10 * RATE)):
        time, x = k / RATE, k / RATE
        ids = [1, 2, 3]
        azimuth = list(np.arctan2(BEACONS[:, 1], BEACONS[:, 0] - x))
        for beacon, azimuths in extra.items():
            if np.isfinite(azimuths[k]):
                ids.append(beacon)
                azimuth.append(azimuths[k])
        sample_times = time - np.arange(SAMPLES)[::-1] / (RATE * SAMPLES) if k else np.zeros(0)
        n = sample_times.size
        odometry = OdometrySamples(sample_times, np.ones(n), np.zeros(n))
        imu = ImuSamples(sample_times.copy(), np.zeros(n), np.zeros((n, 2)), np.full(n, np.nan))
        frames.append(SurveyFrame(time, Measurements(np.array(ids), np.array(azimuth)),
                                  Motion(time, odometry, imu)))
    return Drive(tuple(frames), (0.0, 0.0, 0.0), "the test drive")


def phantom_azimuths() -> list[float]:
    """A misread id seen in every frame, its rays all meeting at :data:`PHANTOM`."""
    return [float(np.arctan2(PHANTOM[1], PHANTOM[0] - k / RATE)) for k in range(100)]


def prior_map() -> BeaconMap:
    """Beacons 1-3 at their true positions."""
    return BeaconMap(np.array([1, 2, 3]), np.column_stack([BEACONS, np.zeros(3)]),
                     np.full(3, 0.03))


def test_an_id_the_prior_map_lacks_is_not_surveyed_but_counted() -> None:
    result = survey(drive({21: phantom_azimuths()}), Prior(prior_map(), (1, 2)))
    b = result.ids.tolist().index(21)
    assert not result.observable[b]
    assert np.isnan(result.xy[b]).all() and np.isnan(result.covariances[b]).all()
    assert result.rays[b] == 100
    assert result.reasons[b] == "not in the prior map: seen 100 times"
    assert 21 not in result.beacon_map(prior_map()).ids
    assert result.observable[[i != 21 for i in result.ids.tolist()]].all()
    assert result.moved == ()


def test_without_a_prior_a_meeting_id_is_a_beacon() -> None:
    """Nothing tells a misread id whose rays meet from a beacon when no map is given."""
    result = survey(drive({21: phantom_azimuths()}))
    b = result.ids.tolist().index(21)
    assert result.observable[b]
    np.testing.assert_allclose(result.xy[b], PHANTOM, atol=0.02)


def test_without_a_prior_a_rare_or_scattered_misread_id_is_unobservable() -> None:
    rare = [np.nan] * 100
    rare[10] = rare[60] = 0.7
    scattered = list(np.random.default_rng(0).uniform(-np.pi, np.pi, 100))
    result = survey(drive({22: rare, 23: scattered}))
    reasons = dict(zip(result.ids.tolist(), result.reasons, strict=True))
    observable = dict(zip(result.ids.tolist(), result.observable.tolist(), strict=True))
    assert not observable[22] and reasons[22] == "seen 2 times, fewer than 3"
    assert not observable[23] and reasons[23].startswith(("its rays do not meet",
                                                          "its azimuths disagree"))
    assert all(observable[i] for i in (1, 2, 3))



def test_a_map_of_the_anchors_alone_lets_every_id_be_surveyed() -> None:
    """A map unknown but for two beacons: the others, and the misread id, are to be found."""
    anchors = BeaconMap(np.array([1, 2]), np.column_stack([BEACONS[:2], np.zeros(2)]))
    result = survey(drive({21: phantom_azimuths()}), Prior(anchors, (1, 2)))
    assert result.ids.tolist() == [1, 2, 3, 21] and result.observable.all()
