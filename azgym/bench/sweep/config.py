"""A sweep's configuration: localizers x hyperparameter grids x suites x seeds, from a TOML file.

Every field is checked before anything runs, and a problem is named by the file and the field
(``sweep.toml: localizer[0].grid.max_iter: Ransac.max_iter must be an integer >= 1, got 0``). The
format (docs/scaling.md)::

    suites = ["warehouse-static"]   # frame suites
    scenarios = ["warehouse-large"] # and/or scenarios (names or .toml files beside this one):
                                    # random poses in each, as shipped; at least one of the two
                                    # (each suite is scored on its own shipped maps, each
                                    # scenario on its own: mixing the two changes no row)
    seeds = [7, 8]                  # draws of each suite (default: each suite's dev seed)
    quick = true                    # the suites' small versions (default: false)
    time_limit = 10.0               # seconds a localizer may take on one frame
    metric = "p75_all_cm"           # the figure's metric (default: the headline, p75_all_cm)

    [[localizer]]
    name = "ransac"                 # a name, preset or plug-in spec, as --localizer takes it
    params = { weighted = true }    # fixed hyperparameters (optional)
    grid = { max_iter = [5, 20] }   # each combination of these values is one grid point

A localizer without ``grid`` is one point. Grid points are numbered in the file's order: each
localizer in turn, its grid's combinations with the last key varying fastest.
"""

from __future__ import annotations

import itertools
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from azgym import arguments
from azgym.arguments import time_limit as checked_time_limit
from azgym.bench.run.contenders import Contender, contender, resolve_contenders
from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT, build_problem
from azgym.bench.suites import Suite
from azgym.bench.suites.warehouse import scenario_suite
from azgym.core import BeaconMap
from azgym.errors import AzgymError, InvalidInputError, unknown_name
from azgym.fields import Fields
from azgym.localize.registry import spec_label
from azgym.metrics import HEADLINE
from azgym.site import Scenario, load_scenario

__all__ = ["GridPoint", "MAX_RUNS", "SweepConfig", "load_sweep", "parse_sweep"]

MAX_RUNS = 1000
"""At most this many grid points x suites x seeds in one sweep: a grid larger than that is
more likely a typo (a list of 100 values) than a plan, and would take hours."""
METRICS = (HEADLINE, "p75_cm", "median_cm", "mean_cm", "p95_cm", "rmse_cm", "availability",
           "failure_rate")
"""The metrics a sweep's figure can show (from each run's overall figures); the first, the
headline (every frame, a refusal infinite), by default."""
KEYS = {"suites", "scenarios", "seeds", "quick", "time_limit", "metric", "localizer"}
LOCALIZER_KEYS = {"name", "params", "grid"}
SCALARS = (bool, int, float, str)
"""The types a hyperparameter's value may have: JSON scalars, as a spec writes them (a TOML
date, array or table is refused by name)."""


@dataclass(frozen=True)
class GridPoint:
    """One localizer with one combination of hyperparameters.

    Attributes:
        contender: What the runner runs (its label is the canonical spec).
        target: The localizer's name or spec, without hyperparameters.
        varied: The grid's hyperparameters at this point (the fixed ones are in the label).
    """

    contender: Contender
    target: str
    varied: dict[str, Any]


@dataclass(frozen=True)
class SweepConfig:
    """A checked sweep: who runs, on what, and how it is shown."""

    points: list[GridPoint]
    suites: list[Suite]
    seeds: list[int] | None
    quick: bool
    time_limit: float
    metric: str
    maps: dict[str, dict[str, BeaconMap]] = field(default_factory=dict)
    """The beacon maps each suite of the scenario axis is scored on, by suite name
    (``static:<scenario>``: its scenario's map alone). A suite of ``suites`` is not here: it
    is scored on its own shipped scenarios' maps, whatever the scenario axis holds (a scenario
    file may even share a shipped scenario's name)."""

    @property
    def runs(self) -> int:
        """How many (grid point, suite, seed) runs the sweep holds."""
        return len(self.points) * len(self.suites) * len(self.seeds or [0])


class _Fields(Fields):
    """The config's fields (:class:`~azgym.fields.Fields`), and the checks only a sweep has."""

    def names(self, field: str, value: Any, known: list[str]) -> list[str]:
        items = self.nonempty_list(field, value)
        for k, item in enumerate(items):
            if item not in known:
                raise self.fail(f"{field}[{k}]", str(unknown_name(field[:-1], str(item), known)))
        return items

    def nonempty_list(self, field: str, value: Any) -> list[Any]:
        if not isinstance(value, list) or not value:
            raise self.fail(field, f"must be a non-empty list, got {value!r}")
        if len({repr(v) for v in value}) < len(value):
            raise self.fail(field, f"lists a value twice: {value!r}")
        return value

    def seeds(self, value: Any) -> list[int] | None:
        if value is None:
            return None
        try:
            return [arguments.seed(f"seeds[{k}]", seed)
                    for k, seed in enumerate(self.nonempty_list("seeds", value))]
        except InvalidInputError as exc:
            raise InvalidInputError(f"{self.origin}: {exc}") from None


def load_sweep(path: Path) -> SweepConfig:
    """Read and check a sweep's TOML file; every grid point is built once, as a run would.

    Raises:
        InvalidInputError: The file, or one of its fields, named with the problem.
    """
    source = str(path)
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InvalidInputError(f"{source}: cannot read the sweep file ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InvalidInputError(f"{source}: not a TOML file ({exc})") from None
    except RecursionError:  # tomllib recurses once per nested array or inline table
        raise InvalidInputError(f"{source}: not a TOML file (arrays or tables nested too "
                                "deeply)") from None
    return parse_sweep(data, source, Path(path).parent)


def parse_sweep(data: dict[str, Any], source: str = "sweep",
                folder: Path | None = None) -> SweepConfig:
    """Check a sweep's fields (as read from TOML); see :func:`load_sweep`.

    ``folder`` is where scenario files are looked for (the config's own folder).
    """
    from azgym.bench.suites import SUITES

    fields = _Fields(source)
    fields.keys(data, KEYS)
    if data.get("suites") is None and data.get("scenarios") is None:
        raise fields.fail("suites", "a sweep needs suites, scenarios or both")
    suites = [SUITES[name] for name in (
        fields.names("suites", data["suites"], list(SUITES)) if "suites" in data else [])]
    scenarios = _scenarios(fields, data.get("scenarios"), folder or Path.cwd())
    axis = [scenario_suite(scenario) for scenario in scenarios]
    suites += axis
    seeds = fields.seeds(data.get("seeds"))
    quick = fields.boolean(data.get("quick", False), "quick")
    try:
        time_limit = checked_time_limit("time_limit", data.get("time_limit", DEFAULT_TIME_LIMIT))
    except InvalidInputError as exc:
        raise fields.fail("time_limit", str(exc).removeprefix("time_limit ")) from None
    metric = data.get("metric", METRICS[0])
    if metric not in METRICS:
        raise fields.fail("metric", str(unknown_name("metric", str(metric), METRICS)))
    tables = data.get("localizer")
    if not isinstance(tables, list) or not tables:
        raise fields.fail("localizer", "at least one [[localizer]] table is needed")
    grids = [_grid(fields, f"localizer[{k}]", table) for k, table in enumerate(tables)]
    runs = sum(len(g) for g in grids) * len(suites) * len(seeds or [0])
    if runs > MAX_RUNS:
        raise fields.fail("localizer", f"the sweep holds {runs} runs (grid points x suites x "
                                       f"seeds), more than the cap of {MAX_RUNS}")
    points = _points(fields, tables, grids, time_limit)
    return SweepConfig(points, suites, seeds, quick, time_limit, metric,
                       {suite.name: {scenario.name: scenario.beacons}
                        for suite, scenario in zip(axis, scenarios, strict=True)})


def _scenarios(fields: _Fields, value: Any, folder: Path) -> list[Scenario]:
    """The scenarios of the scenario axis: shipped names, or files relative to ``folder``."""
    if value is None:
        return []
    scenarios = []
    for k, name in enumerate(fields.nonempty_list("scenarios", value)):
        if not isinstance(name, str) or not name.strip():
            raise fields.fail(f"scenarios[{k}]", f"must be a name or a .toml file, got {name!r}")
        where = _beside(fields, f"scenarios[{k}]", folder, name) if name.endswith(".toml") \
            else name
        try:
            scenarios.append(load_scenario(where))
        except AzgymError as exc:
            raise fields.fail(f"scenarios[{k}]", str(exc)) from None
    names = [scenario.name for scenario in scenarios]
    if len(set(names)) < len(names):
        raise fields.fail("scenarios", f"two scenarios share a name: {names}")
    return scenarios


def _beside(fields: _Fields, field: str, folder: Path, name: str) -> Path:
    """A scenario file of the config: in the config's folder or below it, nowhere else.

    A config names files relative to itself, so it can be shared with its scenarios; one that
    reached outside (``/etc/...``, ``../../x.toml``) would read whatever the runner's machine
    has there. Links are resolved first: a link out of the folder is refused too.
    """
    path = folder / name
    if not path.resolve().is_relative_to(folder.resolve()):
        raise fields.fail(field, f"{name!r} is outside the config's folder; a scenario file "
                                 "must be in the config's folder or below it")
    return path


def _grid(fields: _Fields, field: str, table: Any) -> list[dict[str, Any]]:
    """A localizer table's grid: every combination of its values (one point without a grid)."""
    if not isinstance(table, dict):
        raise fields.fail(field, "must be a table ([[localizer]])")
    fields.keys(table, LOCALIZER_KEYS, field)
    if not isinstance(table.get("name"), str) or not table["name"]:
        raise fields.fail(f"{field}.name", "a localizer's name or spec is needed")
    if not isinstance(table.get("params", {}), dict):
        raise fields.fail(f"{field}.params", "must be a table of hyperparameters")
    for key, value in table.get("params", {}).items():
        _scalar(fields, f"{field}.params.{key}", value)
    grid = table.get("grid", {"": [None]})
    if not isinstance(grid, dict) or not grid:
        raise fields.fail(f"{field}.grid", "is empty: give each hyperparameter a list of "
                                           "values, or leave grid out to run the defaults")
    for key, values in grid.items():
        for value in fields.nonempty_list(f"{field}.grid.{key}", values):
            if key:  # not the one point of a localizer without a grid
                _scalar(fields, f"{field}.grid.{key}", value)
        if key in table.get("params", {}):
            raise fields.fail(f"{field}.grid.{key}", "is also fixed in params")
    keys = [key for key in grid if key]
    return [dict(zip(keys, combo, strict=True))
            for combo in itertools.product(*(grid[key] for key in keys))]


def _scalar(fields: _Fields, field: str, value: Any) -> None:
    """Refuse a hyperparameter's value that is not a JSON scalar (:data:`SCALARS`)."""
    if not isinstance(value, SCALARS):
        raise fields.fail(field, f"must be true, false, a number or a string (a JSON scalar), "
                                 f"got {value!r}")


def _build_problem(base: Contender, params: dict[str, Any], time_limit: float) -> str:
    """Why ``base`` with ``params`` added does not build ("" when it does), as a run builds it."""
    try:
        candidate = contender(spec_label(base.spec, {**base.params, **params}))
    except AzgymError as exc:
        return str(exc)
    return build_problem(candidate.spec, candidate.params, time_limit)


def _culprit(field: str, base: Contender, params: dict[str, Any], varied: dict[str, Any],
             time_limit: float) -> str:
    """The field to blame for a grid point the localizer refuses.

    The first key whose value it refuses alone; the table when it refuses none alone (a
    combination), or does not build without them.
    """
    if not _build_problem(base, {}, time_limit):
        for key, value in params.items():
            if _build_problem(base, {key: value}, time_limit):
                return f"{field}.{'grid' if key in varied else 'params'}.{key}"
    return field


@dataclass(frozen=True)
class _Draft:
    """A grid point as its table writes it: the field, the named localizer and its values."""

    field: str
    base: Contender
    params: dict[str, Any]
    varied: dict[str, Any]

    @property
    def spec(self) -> str:
        """The grid point's canonical spec: the name's hyperparameters and the table's."""
        return spec_label(self.base.spec, {**self.base.params, **self.params})


def _points(fields: _Fields, tables: list[dict[str, Any]], grids: list[list[dict[str, Any]]],
            time_limit: float) -> list[GridPoint]:
    """Each grid point as a contender, built once (a bad name or value is named here).

    The points go through the one rule of who runs
    (:func:`~azgym.bench.run.contenders.resolve_contenders`), two that are the same localizer
    refused; a point that does not build is blamed on the field whose value it refuses.
    """
    drafts: list[_Draft] = []
    for k, (table, grid) in enumerate(zip(tables, grids, strict=True)):
        field = f"localizer[{k}]"
        for varied in grid:
            params = {**table.get("params", {}), **varied}
            try:
                base = contender(table["name"])
            except AzgymError as exc:
                raise fields.fail(field, str(exc)) from None
            for key in sorted(params.keys() & base.params.keys()):
                where = "grid" if key in varied else "params"
                raise fields.fail(f"{field}.{where}.{key}", f"is also fixed in the name "
                                                           f"{table['name']!r}")
            drafts.append(_Draft(field, base, params, varied))

    def repeat(label: str, first: int, again: int) -> AzgymError:
        return fields.fail(drafts[again].field, f"grid point {label!r} is already in the "
                                                f"sweep ({drafts[first].field})")

    by_label: dict[str, _Draft] = {}
    for draft in drafts:  # the first of a label: the one built (a repeat is refused)
        by_label.setdefault(draft.spec, draft)

    def check(candidate: Contender) -> None:
        draft = by_label[candidate.label]
        problem = build_problem(candidate.spec, candidate.params, time_limit)
        if problem:
            raise fields.fail(_culprit(draft.field, draft.base, draft.params, draft.varied,
                                        time_limit), problem)

    chosen = resolve_contenders([draft.spec for draft in drafts], check=check,
                                refuse_repeat=repeat)
    return [GridPoint(candidate, draft.base.spec, draft.varied)
            for candidate, draft in zip(chosen, drafts, strict=True)]
