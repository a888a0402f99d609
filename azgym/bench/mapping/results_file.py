"""A mapping results file read as an adversary's edit: every field of its kind, range and rule.

``mapping.json`` (:mod:`azgym.bench.mapping.report`) is what the board's mapping tables show, so
:func:`load_mapping` trusts nothing in it:

- its layout: the keys of the file, of each mapper, summary and case record are exactly the ones
  azgym writes (an unknown or missing key is refused), at most :data:`MAX_MAPPERS` mappers, each
  once, at most :data:`MAX_BEACONS` beacons and :data:`MAX_FRAMES` frames a case, within the
  leaderboard's byte and nesting caps (:func:`~azgym.bench.leaderboard.entry_files.read_json`),
  a time limit of at most :data:`MAX_TIME_LIMIT`;
- its suite exists at the version it was run on, on its dev split and seed (the suite's routes
  are public: it has no test split), and its cases are the suite's, in order;
- its mappers are azgym's own (:data:`~azgym.mapping.registry.MAPPERS`' built-ins, their specs
  building): a plug-in named in a file is never run by ``azgym leaderboard verify``;
- each case record obeys the scoring's rules: a placed beacon has a position (a finite error),
  a beacon never seen has no delay, a delay lies within the checkpoints' window, ``said`` is
  whether the case's ``said_moved`` names the beacon, ``false_moves`` counts the moves said of
  beacons that did not move, a failed call has a reason and no runtime;
- what does not depend on the mapper does not: every mapper's record of a case scores the same
  beacons, the same moved beacons seen at the same times, and ransac's errors on the true map;
- each summary is recomputed from the mapper's case records by the run's own rule
  (:func:`~azgym.bench.mapping.scoring.summarize`) and compared, figure by figure: a file whose
  summary does not follow from its cases is refused. ``azgym leaderboard verify`` then reruns
  the cases (:func:`~azgym.bench.mapping.board.verify_mapping`).

A refusal names the file, the mapper, the case and the field.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from azgym.arguments import MIN_TIME_LIMIT
from azgym.bench.leaderboard.checks import clean, close
from azgym.bench.leaderboard.entry_files import LeaderboardError, exact_keys, read_json
from azgym.bench.mapping.report import KIND, RESULTS_FORMAT
from azgym.bench.mapping.scoring import (
    DELAY_WINDOW,
    BeaconScore,
    CaseScore,
    MapperSummary,
    MovedScore,
    summarize,
)
from azgym.bench.mapping.suites import MAPPING_SUITES, case_names
from azgym.errors import AzgymError

__all__ = ["CASE_CHECKS", "MAX_BEACONS", "MAX_FRAMES", "MAX_MAPPERS", "MAX_TIME_LIMIT",
           "MappingFile", "is_mapping_file", "load_mapping"]

MAX_MAPPERS = 16
"""At most this many mappers in a file (the built-ins are 4): a rerun surveys every case for
each, so a padded file must not cost hours."""
MAX_BEACONS = 1000
"""At most this many scored, moved or said-moved beacons in a case (the suite's sites have
fewer than 100)."""
MAX_FRAMES = 100_000
"""At most this many frames in a case (the suite's longest drive has a few thousand)."""
MAX_TEXT = 64
"""The longest identity text (version, Python, timestamp) [characters]."""
MAX_REASON = 2000
"""The longest failure reason [characters]."""
MAX_CHECKPOINT_FAILURES = 10_000
MAX_TIME_LIMIT = 600.0
"""The longest time limit a file may name [s]: ``azgym leaderboard verify`` waits that long for a
call at worst, so a forged limit must not make a rerun last days."""
FILE_KEYS = {"kind", "format", "suite", "suite_version", "split", "seed", "quick",
             "time_limit_s", "azgym_version", "python", "timestamp", "cases", "mappers"}
MAPPER_KEYS = {"mapper", "summary", "cases"}
SUMMARY_KEYS = {field.name for field in dataclasses.fields(MapperSummary)} - {"mapper"}
"""A summary's keys: :class:`MapperSummary`'s fields but the mapper's name."""


@dataclass(frozen=True)
class MappingFile:
    """A checked mapping results file.

    Attributes:
        path: Where it was read from.
        record: Its content as the file holds it (JSON types; null for inf and NaN).
        scores: Per mapper, its case scores as read (null back to inf).
        summaries: Per mapper, its summary recomputed from ``scores`` (equal to the file's).
    """

    path: Path
    record: dict[str, Any]
    scores: dict[str, tuple[CaseScore, ...]]
    summaries: dict[str, MapperSummary]


def is_mapping_file(path: Path) -> bool:
    """Whether ``path`` is a mapping results file; one that cannot be read is not."""
    try:
        data = read_json(path, "results file")
    except LeaderboardError:
        return False
    return isinstance(data, dict) and data.get("kind") == KIND


def load_mapping(path: Path) -> MappingFile:
    """A mapping results file, every check of the module docstring passed.

    Raises:
        LeaderboardError: Naming the file and the field at fault.
    """
    data = read_json(path, "mapping results file")
    if not isinstance(data, dict) or data.get("kind") != KIND:
        raise LeaderboardError(f"{path}: not a mapping results file (kind {KIND!r})")
    if type(data.get("format")) is not int or data["format"] != RESULTS_FORMAT:
        raise LeaderboardError(f"{path}: format must be {RESULTS_FORMAT}, got "
                               f"{data.get('format')!r}")
    exact_keys(data, FILE_KEYS, str(path))
    for key in ("azgym_version", "python", "timestamp"):
        if not isinstance(data[key], str) or len(data[key]) > MAX_TEXT:
            raise LeaderboardError(f"{path}: {key}: must be a text of at most {MAX_TEXT} "
                                   "characters")
    cases = _check_suite(data, path)
    mappers = data["mappers"]
    if not isinstance(mappers, list) or not 0 < len(mappers) <= MAX_MAPPERS:
        raise LeaderboardError(f"{path}: mappers must be a list of 1 to {MAX_MAPPERS}")
    scores: dict[str, tuple[CaseScore, ...]] = {}
    for k, mapper in enumerate(mappers):
        where = f"{path}: mappers/{k}"
        exact_keys(mapper, MAPPER_KEYS, where)
        name = _check_mapper(mapper["mapper"], f"{where}/mapper")
        if name in scores:
            raise LeaderboardError(f"{where}/mapper: {name} is in the file twice")
        scores[name] = _cases(mapper["cases"], cases, f"{where} ({name})")
    _check_shared(scores, path)
    summaries = {name: _check_summary(mapper["summary"], name, scores[name],
                                      f"{path}: mappers/{k} ({name})")
                 for k, (name, mapper) in enumerate(zip(scores, mappers, strict=True))}
    return MappingFile(path, data, scores, summaries)


def _check_suite(data: dict[str, Any], path: Path) -> list[str]:
    """The file's suite, at its version, on its dev split, seed and size; its cases' names."""
    if not isinstance(data["suite"], str) or data["suite"] not in MAPPING_SUITES:
        raise LeaderboardError(f"{path}: suite {data['suite']!r} is not a mapping suite "
                               f"({', '.join(MAPPING_SUITES)})")
    suite = MAPPING_SUITES[data["suite"]]
    if type(data["suite_version"]) is not int or data["suite_version"] != suite.version:
        raise LeaderboardError(f"{path}: suite_version {data['suite_version']!r}: "
                               f"{suite.name} is at version {suite.version}; rerun it")
    if data["split"] != "dev" or type(data["seed"]) is not int or \
            data["seed"] != suite.dev_seed:
        raise LeaderboardError(f"{path}: a mapping suite has a dev split only (its routes are "
                               f"public), on seed {suite.dev_seed}: got split "
                               f"{data['split']!r}, seed {data['seed']!r}")
    if not isinstance(data["quick"], bool):
        raise LeaderboardError(f"{path}: quick must be true or false")
    _number(data["time_limit_s"], f"{path}: time_limit_s [s]", MIN_TIME_LIMIT, MAX_TIME_LIMIT)
    names = case_names(data["quick"])
    if data["cases"] != names:
        raise LeaderboardError(f"{path}: cases must be the {suite.name} suite's "
                               f"{'quick' if data['quick'] else 'full'} cases, in order: "
                               f"{', '.join(names)}")
    return names


def _check_mapper(spec: Any, where: str) -> str:
    """A built-in mapper's spec that builds (a board runs no plug-in named in a file)."""
    from azgym.mapping.registry import MAPPERS, make_mapper
    from azgym.registry import split_spec

    try:
        builtin = isinstance(spec, str) and len(spec) <= MAX_TEXT and \
            split_spec(spec, "mapper")[0] in MAPPERS.names(plugins=False)
        if builtin:
            make_mapper(spec)
    except AzgymError as exc:
        raise LeaderboardError(f"{where}: {spec!r} does not build: {exc}") from None
    if not builtin:
        raise LeaderboardError(f"{where}: {spec!r} is not a built-in mapper (a board runs "
                               "no plug-in named in a file)")
    return spec


def _real(value: Any) -> bool:
    """A finite float, or an int a float holds exactly; no bool.

    JSON's integers are unbounded: 10^400 would overflow wherever a float is made of it.
    """
    return (type(value) is float and math.isfinite(value)) or \
        (type(value) is int and abs(value) <= 2**53)


def _number(value: Any, where: str, low: float = 0.0, high: float = math.inf,
            null: bool = False) -> float:
    """A finite number (no bool) in [low, high]; null (read as inf) where ``null`` allows it."""
    if value is None and null:
        return math.inf
    if not _real(value) or not low <= value <= high:
        bounds = f"≥ {low:g}" if math.isinf(high) else f"from {low:g} to {high:g}"
        raise LeaderboardError(f"{where}: must be a finite number {bounds}"
                               + (" or null" if null else ""))
    return float(value)


def _whole(value: Any, where: str, high: int) -> int:
    """A whole number (no bool) in [0, high]."""
    if type(value) is not int or not 0 <= value <= high:
        raise LeaderboardError(f"{where}: must be a whole number from 0 to {high}")
    return value


def _text(value: Any, where: str, high: int) -> str:
    if not isinstance(value, str) or not 0 < len(value) <= high:
        raise LeaderboardError(f"{where}: must be a text of 1 to {high} characters")
    return value


def _items(value: Any, where: str, high: int) -> list[Any]:
    if not isinstance(value, list) or len(value) > high:
        raise LeaderboardError(f"{where}: must be a list of at most {high}")
    return value


def _ids(values: list[int], where: str) -> None:
    if len(set(values)) != len(values):
        raise LeaderboardError(f"{where}: names a beacon twice")


def _beacons(value: Any, where: str) -> tuple[BeaconScore, ...]:
    beacons = []
    for k, item in enumerate(_items(value, where, MAX_BEACONS)):
        at = f"{where}/{k}"
        exact_keys(item, {"beacon", "error", "placed"}, at)
        if not isinstance(item["placed"], bool):
            raise LeaderboardError(f"{at}/placed: must be true or false")
        error = _number(item["error"], f"{at}/error", null=not item["placed"])
        beacons.append(BeaconScore(_whole(item["beacon"], f"{at}/beacon", 2**31), error,
                                   item["placed"]))
    _ids([b.beacon for b in beacons], where)
    return tuple(beacons)


def _moved(value: Any, where: str) -> tuple[MovedScore, ...]:
    moved = []
    for k, item in enumerate(_items(value, where, MAX_BEACONS)):
        at = f"{where}/{k}"
        exact_keys(item, {"beacon", "said", "seen", "delay"}, at)
        if not isinstance(item["said"], bool):
            raise LeaderboardError(f"{at}/said: must be true or false")
        seen = _number(item["seen"], f"{at}/seen", null=True)
        if item["delay"] is not None and item["seen"] is None:
            raise LeaderboardError(f"{at}/delay: a beacon never seen has no delay")
        delay = _number(item["delay"], f"{at}/delay", high=DELAY_WINDOW, null=True)
        moved.append(MovedScore(_whole(item["beacon"], f"{at}/beacon", 2**31), item["said"],
                                None if math.isinf(seen) else seen,
                                None if math.isinf(delay) else delay))
    _ids([m.beacon for m in moved], where)
    return tuple(moved)


def _errors(value: Any, where: str) -> tuple[float, ...]:
    items = _items(value, where, MAX_FRAMES)
    return tuple(_number(item, f"{where}/{k}", null=True) for k, item in enumerate(items))


CASE_CHECKS: dict[str, Callable[[Any, str], Any]] = {
    "case": lambda value, where: _text(value, where, 200),
    "scenario": lambda value, where: _text(value, where, 200),
    "route": lambda value, where: _text(value, where, 200),
    "perturbation": lambda value, where: _text(value, where, 200),
    "beacons": _beacons,
    "moved": _moved,
    "said_moved": lambda value, where: tuple(
        _whole(item, f"{where}/{k}", 2**31)
        for k, item in enumerate(_items(value, where, MAX_BEACONS))),
    "false_moves": lambda value, where: _whole(value, where, MAX_BEACONS),
    "localization_updated": _errors,
    "localization_true": _errors,
    "failure": lambda value, where: None if value is None else _text(value, where, MAX_REASON),
    "checkpoint_failures": lambda value, where: _whole(value, where, MAX_CHECKPOINT_FAILURES),
    "runtime": lambda value, where: None if value is None else _number(value, where),
}
"""How each field of a case record is read, by :class:`CaseScore`'s field names (all of them)."""


def _cases(value: Any, names: list[str], where: str) -> tuple[CaseScore, ...]:
    """A mapper's case records, one per case of the suite, in order, each read and checked."""
    if not isinstance(value, list) or len(value) != len(names):
        raise LeaderboardError(f"{where}/cases: must be a record of each of the file's "
                               f"{len(names)} cases")
    scores = []
    for k, (item, name) in enumerate(zip(value, names, strict=True)):
        at = f"{where}/cases/{k}"
        exact_keys(item, set(CASE_CHECKS), at)
        read = {key: check(item[key], f"{at}/{key}") for key, check in CASE_CHECKS.items()}
        if read["case"] != name or name != "/".join(
                (read["scenario"], read["route"], read["perturbation"])):
            raise LeaderboardError(f"{at}: must be the case {name} (its scenario, route and "
                                   "perturbation)")
        scores.append(_check_case(CaseScore(**read), f"{at} ({name})"))
    return tuple(scores)


def _check_case(score: CaseScore, where: str) -> CaseScore:
    """The rules between a case record's fields (module docstring)."""
    said = set(score.said_moved)
    if list(score.said_moved) != sorted(said):
        raise LeaderboardError(f"{where}/said_moved: must be distinct ids in increasing order")
    for k, moved in enumerate(score.moved):
        if moved.said != (moved.beacon in said):
            raise LeaderboardError(f"{where}/moved/{k}/said: must be whether said_moved names "
                                   f"beacon {moved.beacon}")
    false = len(said - {moved.beacon for moved in score.moved})
    if score.false_moves != false:
        raise LeaderboardError(f"{where}/false_moves: the file says {score.false_moves}, its "
                               f"said_moved and moved give {false}")
    if len(score.localization_updated) != len(score.localization_true) or \
            not score.localization_true:
        raise LeaderboardError(f"{where}: localization_updated and localization_true must "
                               "hold the same frames, at least one")
    if (score.failure is None) != (score.runtime is not None):
        raise LeaderboardError(f"{where}: a failed call has a reason and no runtime, any other "
                               "a runtime and no reason")
    return score


def _check_summary(value: Any, mapper: str, scores: tuple[CaseScore, ...],
                   where: str) -> MapperSummary:
    """The file's summary of a mapper, figure by figure the one its case records give."""
    exact_keys(value, SUMMARY_KEYS, f"{where}/summary")
    summary = summarize(mapper, scores)
    recomputed = clean(dataclasses.asdict(summary))
    for key in sorted(SUMMARY_KEYS):
        claimed, actual = value[key], recomputed[key]
        if not (claimed is None or _real(claimed)) or not close(claimed, actual):
            raise LeaderboardError(f"{where}/summary/{key}: the file says {claimed!r}, its "
                                   f"cases give {actual!r}")
    return summary


def _check_shared(scores: dict[str, tuple[CaseScore, ...]], path: Path) -> None:
    """Every mapper's record of a case agrees on what does not depend on the mapper."""
    first, *others = scores
    for other in others:
        for one, two in zip(scores[first], scores[other], strict=True):
            shared = [("beacons", [b.beacon for b in one.beacons],
                       [b.beacon for b in two.beacons]),
                      ("moved", [(m.beacon, m.seen) for m in one.moved],
                       [(m.beacon, m.seen) for m in two.moved]),
                      ("localization_true", one.localization_true, two.localization_true)]
            for key, mine, theirs in shared:
                if mine != theirs:
                    raise LeaderboardError(
                        f"{path}: {one.case}: {key} differ between {first} and {other}, and "
                        "they do not depend on the mapper (the truth scores every mapper "
                        "alike)")
