"""``check_mapper``: the conformance checks every mapper, built-in or plug-in, should pass.

Like :func:`azgym.check_localizer` and :func:`azgym.check_tracker`: run it in your test suite,
and a failure names the check and what went wrong. The drive is built by hand, so its answer is
known exactly (:func:`line_drive`): a camera driven straight for 10 s at 1 m/s, its odometry and
gyro exact, each frame's azimuths to every beacon exact; beacons 1 and 2 are the anchors. A
check asks what a correct mapper must do whatever its method: what it places is where the
beacons are, it says no beacon moved that did not, it is deterministic and leaves its inputs as
they were, and it refuses an empty drive by name. A mapper that places nothing passes those;
how much a mapper finds is what the mapping benchmark scores.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from azgym.core import BeaconMap, Measurements
from azgym.errors import AzgymError, InvalidInputError, MapperCheckError
from azgym.mapping.base import MAX_BEACONS, MapAnswer, Mapper
from azgym.mapping.problem import Drive, Prior, SurveyFrame
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples

__all__ = ["ANCHORS", "MapperCheckError", "check_mapper", "checked_answer", "line_drive",
           "world"]

ANCHORS = (1, 2)
"""The anchors of the checks' drives."""
SHIFTED = 5
"""The beacon a stale prior map holds 1 m from where it is."""


def world() -> BeaconMap:
    """The checks' beacons: six on both sides of a 10 m straight drive along the x axis."""
    xy = np.array([[0.0, 4.0], [10.0, -4.0], [3.0, 3.0], [6.0, -3.5], [8.0, 5.0], [12.0, 2.5]])
    return BeaconMap(np.arange(1, 7), np.column_stack([xy, np.full(6, 3.0)]), width=0.03)


def line_drive(beacons: BeaconMap, seconds: float = 10.0, speed: float = 1.0,
               detect: bool = True) -> Drive:
    """A camera driven from the origin along the x axis, every reading exact.

    Frames at 10 Hz; odometry (speed, no steering) and gyro (no turn) at 50 Hz, each frame
    holding the samples since the previous one; each frame's azimuths to every beacon of
    ``beacons`` (none with ``detect`` false); the start pose known.
    """
    times = np.round(np.arange(0.0, seconds + 1e-9, 0.1), 9)
    samples = np.round(np.arange(0.0, seconds + 1e-9, 0.02), 9)
    frames = []
    for k, time in enumerate(times.tolist()):
        mine = samples[(samples > times[k - 1]) & (samples <= time)] if k else samples[:1]
        odometry = OdometrySamples(mine, np.full(mine.size, speed), np.zeros(mine.size))
        imu = ImuSamples(mine, np.zeros(mine.size), np.zeros((mine.size, 2)),
                         np.full(mine.size, math.nan))
        offsets = beacons.xyz[:, :2] - np.array([speed * time, 0.0])
        measurements = Measurements(beacons.ids, np.arctan2(offsets[:, 1], offsets[:, 0])) \
            if detect else Measurements(np.zeros(0, np.int64), np.zeros(0))
        frames.append(SurveyFrame(time, measurements, Motion(time, odometry, imu)))
    return Drive(tuple(frames), (0.0, 0.0, 0.0), "the checks' drive")


def checked_answer(answer: object, prior: Prior) -> MapAnswer:
    """A mapper's answer, checked again whatever made it, and against the prior.

    A :class:`MapAnswer` is checked when made; one made around its checks (or any other object)
    is refused here. Its moved beacons must be the prior map's, none an anchor.

    Raises:
        InvalidInputError: Not a MapAnswer, a malformed one, or moved beacons the prior does not
            hold or holds as anchors.
    """
    if not isinstance(answer, MapAnswer):
        raise InvalidInputError(f"a mapper must answer a MapAnswer, got {type(answer).__name__}")
    if not isinstance(answer.moved, tuple | list) or len(answer.moved) > MAX_BEACONS:
        raise InvalidInputError(f"MapAnswer.moved must be a tuple of at most {MAX_BEACONS} ids, "
                                f"got a {type(answer.moved).__name__}")
    again = MapAnswer(answer.ids, answer.xy, answer.covariances, answer.moved)
    held = set() if prior.beacons is None else set(prior.beacons.ids.tolist()) - \
        set(prior.anchors)
    stray = [i for i in again.moved if i not in held]
    if stray:
        raise InvalidInputError(f"MapAnswer.moved names beacons that are not the prior map's "
                                f"(anchors aside): {stray[:10]}")
    return again


def _expect(condition: bool, check: str, detail: str) -> None:
    if not condition:
        raise MapperCheckError(f"check_mapper: {check}: {detail}")


def _cases() -> dict[str, tuple[Drive, Prior]]:
    """The checks' drives and priors, by what each asks.

    Made afresh for each check: a mapper that changes its inputs changes no other check's.
    """
    truth = world()
    drive = line_drive(truth)
    anchors = np.isin(truth.ids, ANCHORS)
    xyz = truth.xyz.copy()
    xyz[truth.ids == SHIFTED, 1] += 1.0
    return {
        "the map unknown but for two anchors": (drive, Prior(BeaconMap(
            truth.ids[anchors], truth.xyz[anchors], truth.width[anchors]), ANCHORS)),
        "a stale map (one beacon 1 m off)": (drive, Prior(BeaconMap(truth.ids, xyz, 0.03),
                                                            ANCHORS)),
        "the true map": (drive, Prior(truth, ANCHORS)),
        "a drive that detects nothing": (line_drive(truth, detect=False), Prior(truth, ANCHORS)),
    }


def _survey(mapper: Any, check: str, drive: Drive, prior: Prior) -> MapAnswer:
    """The mapper's answer, checked; any failure named as the check's."""
    try:
        return checked_answer(mapper.survey(drive, prior), prior)
    except Exception as exc:  # noqa: BLE001 - any failure of a plug-in is the check's failure
        raise MapperCheckError(f"check_mapper: {check}: {type(exc).__name__}: {exc}") from None


def _check_case(mapper: Any, name: str, drive: Drive, prior: Prior, tol: float) -> MapAnswer:
    """One case: placed beacons where they are, nothing moved that did not, prior kept."""
    answer = _survey(mapper, f"a MapAnswer for {name}", drive, prior)
    truth = world()
    where = dict(zip(truth.ids.tolist(), truth.xyz[:, :2], strict=True))
    for beacon, xy in zip(answer.ids.tolist(), answer.xy, strict=True):
        _expect(beacon in where, f"places only beacons that are there ({name})",
                f"placed id {beacon}, which no beacon has")
        error = math.dist(xy, where[beacon])
        _expect(error <= tol, f"places beacons where they are ({name})",
                f"beacon {beacon} placed {error:.4f} m off (more than {tol:g} m)")
    false = [i for i in answer.moved if i != SHIFTED]
    _expect(not false, f"says no beacon moved that did not ({name})",
            f"said {false} moved")
    if not drive.frames[-1].measurements.ids.size:
        _expect(answer.ids.size == 0, f"places nothing from nothing ({name})",
                f"placed {answer.ids.tolist()[:10]} from a drive that detected no beacon")
    return answer


def check_mapper(mapper: Any, *, position_tol: float = 0.01, verbose: bool = True) -> None:
    """Run every conformance check on ``mapper``; raise on the first failure.

    Checks, on the hand-built drive (module docstring) with four priors (the map unknown but
    for two anchors, a stale map with one beacon 1 m off, the true map, and a drive that
    detects nothing): it answers a well-formed :class:`MapAnswer` whose moved beacons are the
    prior map's (anchors aside); every beacon it places is one that is there, within
    ``position_tol`` [m]; it says no beacon moved but the one that did; from a drive that
    detects nothing it places nothing; the same call answers the same, bit for bit, and so
    does a fresh copy; it leaves the drive and the prior as they were; an empty drive raises an
    azgym error; for subclasses of :class:`Mapper`, arguments of the wrong type raise an azgym
    error. When every check passes, prints what was checked (unless ``verbose`` is false).

    Raises:
        MapperCheckError: Naming the failed check.
    """
    fresh = copy.deepcopy(mapper)
    answers = {}
    for name, (drive, prior) in _cases().items():
        before = _snapshot(drive, prior)
        answers[name] = _check_case(mapper, name, drive, prior, position_tol)
        _expect(_snapshot(drive, prior) == before, "leaves its inputs as they were",
                f"the drive or the prior changed in the call ({name})")
    name = next(iter(answers))
    drive, prior = _cases()[name]
    for again, who in ((mapper, "the same mapper"), (fresh, "a fresh copy")):
        answer = _survey(again, "determinism", drive, prior)
        _expect(_same(answer, answers[name]), "determinism",
                f"{who} answered the same call differently")
    _expect_raises(lambda: mapper.survey(Drive((), (0.0, 0.0, 0.0), "an empty drive"), prior),
                   "an empty drive raises an azgym error")
    checked = [f"a well-formed MapAnswer for {len(answers)} priors", "places only beacons that "
               f"are there, within {position_tol:g} m", "says no beacon moved that did not",
               "places nothing from a drive that detects nothing", "leaves its inputs as they "
               "were", "determinism", "an empty drive raises an azgym error"]
    if isinstance(mapper, Mapper):
        frames: Any = drive.frames  # a tuple of frames where a Drive belongs
        _expect_raises(lambda: mapper.survey(frames, prior),
                       "arguments of the wrong type raise an azgym error")
        checked.append("arguments of the wrong type raise an azgym error")
    if verbose:
        placed = ", ".join(f"{len(a.ids)}" for a in answers.values())
        print(f"check_mapper: {type(mapper).__name__} passed all {len(checked)} checks (placed "
              f"{placed} beacons):" + "".join(f"\n  passed: {check}" for check in checked))


def _snapshot(drive: Drive, prior: Prior) -> list[object]:
    """Every value of a drive and a prior (arrays as bytes), to see that a call changed none."""
    values: list[object] = [drive.start, prior.anchors]
    if prior.beacons is not None:
        values += [a.tobytes() for a in (prior.beacons.ids, prior.beacons.xyz,
                                         prior.beacons.width)]
    for frame in drive.frames:
        m, o, i = frame.measurements, frame.motion.odometry, frame.motion.imu
        values += [frame.time, frame.motion.time]
        values += [a.tobytes() for a in (m.ids, m.azimuth, o.time, o.speed, o.steer, o.yaw_rate,
                                         i.time, i.yaw_rate, i.accel, i.heading)]
    return values


def _same(a: MapAnswer, b: MapAnswer) -> bool:
    """Whether two answers are the same, bit for bit."""
    return a.moved == b.moved and all(
        x.tobytes() == y.tobytes() for x, y in ((a.ids, b.ids), (a.xy, b.xy),
                                                 (a.covariances, b.covariances)))


def _expect_raises(call: Callable[[], object], check: str) -> None:
    try:
        call()
    except AzgymError:
        return
    except Exception as exc:  # noqa: BLE001 - a plug-in's own exception fails the check
        raise MapperCheckError(f"check_mapper: {check}: it raised {type(exc).__name__}: {exc}"
                               ) from None
    raise MapperCheckError(f"check_mapper: {check}: no azgym error was raised")
