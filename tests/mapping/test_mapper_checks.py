"""check_mapper: every built-in passes, and a mapper broken in one way fails that one check."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import azgym
from azgym.cli import main
from azgym.errors import MapperCheckError
from azgym.mapping import Drive, MapAnswer, Mapper, check_mapper, make_mapper
from azgym.mapping.checks import SHIFTED, world


@pytest.mark.parametrize("spec", ["survey", "rays", "prior", "repair"])
def test_every_built_in_passes(spec, capsys):
    check_mapper(make_mapper(spec))
    assert "passed all 8 checks" in capsys.readouterr().out
    assert azgym.check_mapper is check_mapper


def placing(ids, xy, moved=()) -> MapAnswer:
    return MapAnswer(np.array(ids, np.int64), np.array(xy, float).reshape(-1, 2),
                     np.tile(np.eye(2) * 1e-4, (len(ids), 1, 1)), tuple(moved))


TRUE = {int(i): xy for i, xy in zip(world().ids, world().xyz[:, :2], strict=True)}


class Truthful(Mapper):
    """Places beacon 3 where it is (from a drive that detects it), and nothing else."""

    def __init__(self) -> None:
        self._validate_once()

    def _survey(self, drive, prior):
        if not drive.frames:
            raise azgym.InvalidInputError("no frames")
        seen = drive.frames[0].measurements.ids.size
        return placing([3], [TRUE[3]]) if seen else placing([], [])


class NotAnAnswer(Truthful):
    def _survey(self, drive, prior):
        return {"ids": [3], "xy": [TRUE[3]]}


class Off(Truthful):
    def _survey(self, drive, prior):
        return placing([3], [TRUE[3] + 0.5])


class Invented(Truthful):
    def _survey(self, drive, prior):
        return placing([3, 99], [TRUE[3], (1.0, 1.0)])


class CriesWolf(Truthful):
    def _survey(self, drive, prior):
        held = prior.beacons is not None and 3 in prior.beacons.ids
        return placing([3], [TRUE[3]], moved=[3] if held else [])


class MovesAnAnchor(Truthful):
    def _survey(self, drive, prior):
        return placing([1], [TRUE[1]], moved=[1])


class FromNothing(Truthful):
    def _survey(self, drive, prior):
        return placing([3], [TRUE[3]])


class Restless(Truthful):
    calls = 0

    def _survey(self, drive, prior):
        Restless.calls += 1
        answer = super()._survey(drive, prior)
        return MapAnswer(answer.ids, answer.xy + 1e-9 * Restless.calls, answer.covariances)


class Meddling(Truthful):
    def _survey(self, drive, prior):
        drive.frames[3].motion.odometry.speed[:] = 0.0
        return super()._survey(drive, prior)


class Careless(Truthful):
    def _survey(self, drive, prior):
        return placing([], []) if not drive.frames else super()._survey(drive, prior)


class Untyped(Truthful):
    def survey(self, drive, prior):  # without Mapper's checks of its arguments
        return self._survey(drive if isinstance(drive, Drive) else Drive(tuple(drive)), prior)


class Crashing(Truthful):
    def _survey(self, drive, prior):
        if not drive.frames:
            raise IndexError("tuple index out of range")
        return super()._survey(drive, prior)


@pytest.mark.parametrize(("mapper", "check"), [
    (NotAnAnswer(), "a MapAnswer for the map unknown but for two anchors: InvalidInputError: a "
                    "mapper must answer a MapAnswer, got dict"),
    (Off(), "places beacons where they are (the map unknown but for two anchors): beacon 3 "
            "placed 0.7071 m off"),
    (Invented(), "places only beacons that are there (the map unknown but for two anchors): "
                 "placed id 99"),
    (CriesWolf(), "says no beacon moved that did not (a stale map (one beacon 1 m off)): said "
                  "[3] moved"),
    (MovesAnAnchor(), "a MapAnswer for the map unknown but for two anchors: InvalidInputError: "
                      "MapAnswer.moved names beacons that are not the prior map's (anchors "
                      "aside): [1]"),
    (FromNothing(), "places nothing from nothing (a drive that detects nothing): placed [3]"),
    (Restless(), "determinism: the same mapper answered the same call differently"),
    (Meddling(), "leaves its inputs as they were: the drive or the prior changed in the call "
                 "(the map unknown but for two anchors)"),
    (Careless(), "an empty drive raises an azgym error: no azgym error was raised"),
    (Crashing(), "an empty drive raises an azgym error: it raised IndexError"),
    (Untyped(), "arguments of the wrong type raise an azgym error: no azgym error was raised"),
], ids=lambda value: type(value).__name__ if isinstance(value, Mapper) else "")
def test_a_mapper_broken_in_one_way_fails_that_check(mapper, check):
    check_mapper(Truthful(), verbose=False)  # the mappers differ from this one in one way
    with pytest.raises(MapperCheckError, match=re.escape(f"check_mapper: {check}")):
        check_mapper(mapper, verbose=False)


def test_the_shifted_beacon_may_be_said_moved():
    class Finds(Truthful):
        def _survey(self, drive, prior):
            if not super()._survey(drive, prior).ids.size:
                return placing([], [])
            stale = prior.beacons is not None and not np.allclose(
                prior.beacons.xyz[prior.beacons.ids == SHIFTED, :2], TRUE[SHIFTED])
            return placing([SHIFTED], [TRUE[SHIFTED]], [SHIFTED] if stale else [])

    check_mapper(Finds(), verbose=False)


def test_azgym_check_runs_the_mapper_checks(capsys, tmp_path):
    assert main(["check", "rays"]) == 0
    assert "check_mapper: RaysMapper passed all 8 checks" in capsys.readouterr().out
    path = tmp_path / "off_mapper.py"
    path.write_text("import numpy as np\nfrom azgym.mapping import MapAnswer\n\n\n"
                    "class Off:\n    def survey(self, drive, prior):\n"
                    "        return MapAnswer(np.array([3]), np.array([[0.0, 0.0]]), "
                    "np.eye(2)[None])\n")
    assert main(["check", f"{path}:Off"]) == 2
    assert "check_mapper: places beacons where they are" in capsys.readouterr().err
    assert main(["check", "surve"]) == 2
    assert "Did you mean 'survey'?" in capsys.readouterr().err


def test_the_docs_worked_mapper_runs_as_written_and_passes(tmp_path, capsys, monkeypatch):
    text = (Path(__file__).resolve().parents[2] / "docs" / "mappers.md").read_text()
    blocks = re.findall(r"```(\w+)\n(.*?)```", text, flags=re.S)
    source = next(code for kind, code in blocks if kind == "python" and "class MeetingRays" in
                  code)
    (tmp_path / "meeting_rays.py").write_text(source)
    command = next(code for kind, code in blocks if kind == "bash" and "meeting_rays" in code)
    monkeypatch.chdir(tmp_path)
    assert main(command.split()[1:]) == 0
    assert "check_mapper: MeetingRays passed all 8 checks" in capsys.readouterr().out
    usage = next(code for kind, code in blocks if kind == "python" and "make_mapper(\"meeting" in
                 code)
    scope: dict = {"azgym": azgym}
    exec(usage, scope)
    assert scope["mapper"].get_params() == {"std": 0.02}
