"""Procedural warehouses: ``generate(seed)`` draws a site, valid by construction, seed by seed.

Learned localizers train on generated sites and are tested on held-out seeds and on the shipped
scenarios, so a generated site must look like the shipped warehouses (``envs/warehouse-*.toml``)
without repeating them. What is drawn, in which range, and why:

- **Room**: each side 15-60 m (``SIDE``), from a small store (15 m) to a large hall (the
  shipped warehouse-large is 80 m x 50 m; past 60 m a 40-50 m camera range sees little of the
  far walls). Walls 6-12 m high: the clear height of single-storey warehouses. Half the layouts
  have their racks along x, half along y.
- **Racks** (:mod:`~azgym.site.generator_layout`): rows of single (0.9-1.3 m deep) or
  back-to-back (2.0-2.6 m) racks, 2-8 m high, at least 1 m under the walls' top (pallet racking
  of one to four levels); rows split by cross aisles into racks of 8-25 m; 8 % of the places left
  empty (staging areas). 30 % of the rows have metal faces that mirror 5-15 % of the light (the
  shipped racks mirror 10 %). Aisles 2.8-4.0 m wide, end aisles 3.6-5.0 m and cross aisles
  3.2-4.5 m: the forklift (:class:`~azgym.world.forklift.ForkliftSpec`: 2.4 m x 1.2 m, rear
  steering) turns from an end aisle into a 2.8 m aisle under the pure-pursuit driver (2 m
  lookahead) without touching a rack, as the shipped warehouse-small's 2.8 m aisles and 3-4 m
  crossings show. A quarter of the walls are glass mirroring 5-12 % (the shipped 8 %).
- **Beacons** (:mod:`~azgym.site.generator_beacons`): on 80 % of the aisle ends of the end walls
  (deep in an aisle between tall racks, the walls ahead and behind are all the camera sees) and
  along the side walls every 6-10 m (the shipped sites: every 8-10 m), from the racks' top up to
  9 m; on half the rack ends, 0.2-1 m over the rack, where the aisles on both sides see them;
  lights 2-5 cm wide (the shipped 3 cm). Half the sites have one wall beacon moved 1-2.5 m
  along its wall after mapping (``moved_to``). From random free poses the camera sees three
  beacons or more 94 % of the time on average (the shipped warehouses: 86-95 %).
- **Lights**: ceiling lamps over up to four aisles every 8-14 m, and a sunny window on 30 % of
  the walls: the distractors of the image path, as in warehouse-small.
- **Faults and camera**: a misread rate of 0-2 % (the shipped 0.5-1 %); the lens 2.0-2.6 m up
  (a forklift's overhead guard), its range 35-50 m (the shipped 40-45 m); eq. 1's centre error
  0.5-1.5 px at a horizon radius of 150-300 px (the paper's camera: 1 px at 150-240 px).
- **Bumps**: 40 % of the sites have a 2-5 m bumpy stretch (1-3° of sway) across an aisle.
- **Routes**: a loop along the walls, a serpentine through two to four neighbouring aisles, a
  trip along a cross aisle, and a picking trip that backs out of an aisle, at 1-2.5 m/s.

The site is drawn as TOML-level data (:func:`generate_data`) and built by
:func:`~azgym.site.parse.parse_scenario`, so it passes every check a scenario file passes, and
:func:`generate_toml` writes it as a file that loads back to the same scenario. Each part is
drawn from its own stream of the seed, so the same seed gives the same site, bit for bit.
"""

from __future__ import annotations

import math
import numbers
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from azgym.arguments import whole_number
from azgym.errors import InvalidInputError, ScenarioError
from azgym.files import claim_file, prepare_folder, write_file
from azgym.site.generator_beacons import beacons_data, bumps_data, lights_data
from azgym.site.generator_layout import (
    Plan,
    draw,
    draw_plan,
    racks_data,
    routes_data,
    walls_data,
)
from azgym.site.load import load_scenario
from azgym.site.parse import parse_scenario
from azgym.site.reader import name_problem
from azgym.site.scenario import Scenario
from azgym.site.toml_writer import to_toml

__all__ = ["SIDE", "generate", "generate_data", "generate_toml", "write_generated"]

GENERATOR_VERSION = 1
"""The generated scenarios' ``version``: bumped whenever a seed's site changes."""
SIDE = (15.0, 60.0)
"""The range each side of a random room is drawn from [m]."""
SIDE_LIMITS = (15.0, 100.0)
"""The sides a caller may ask for [m]: a smaller room has no room for two aisles to turn between,
and from the middle of a larger one the far walls are beyond a 35-50 m camera range."""
CAMERA_HEIGHT, CAMERA_RANGE = (2.0, 2.6), (35.0, 50.0)
"""The lens's height [m] and the distance at which a beacon fades below detection [m]."""
CENTER_ERROR_PX, HORIZON_RADIUS_PX = (0.5, 1.5), (150.0, 300.0)
"""Eq. 1's centre-detection error [px] and the fisheye's horizon radius [px]."""
MISDECODE_RATE = (0.0, 0.02)
"""The share of detections whose id is misread."""
_STREAMS = ("room", "racks", "walls", "beacons", "lights", "bumps", "routes", "sensor")


def generate(seed: int, *, size: Sequence[float] | None = None,
             name: str | None = None) -> Scenario:
    """A random warehouse, the same for the same arguments (see the module for what is drawn).

    Args:
        seed: Any integer >= 0.
        size: The room's (east-west, north-south) sides [m], each in ``SIDE_LIMITS``; drawn
            from ``SIDE`` if not given.
        name: The scenario's name (default ``generated-<seed>``).

    Raises:
        InvalidInputError: A bad ``seed``, ``size`` or ``name``, named.
    """
    data = generate_data(seed, size=size, name=name)
    return parse_scenario(data, f"generated scenario (seed {seed})")


def generate_toml(seed: int, *, size: Sequence[float] | None = None,
                  name: str | None = None) -> str:
    """:func:`generate`'s site as the text of a scenario file, which loads back to the same."""
    return _text(seed, size, generate_data(seed, size=size, name=name))


def _text(seed: int, size: Sequence[float] | None, data: dict[str, Any]) -> str:
    """The file's text of generated ``data``, checked by the parser first (never an invalid one)."""
    parse_scenario(data, f"generated scenario (seed {seed})")
    sides = data["room"]["bounds"][2:]
    given = "" if size is None else f", size=({sides[0]:g}, {sides[1]:g})"
    return to_toml(data, f"Generated by azgym.site.generate({seed}{given}), generator version "
                         f"{GENERATOR_VERSION}.\nCoordinates: x east, y north; the origin is "
                         "the south-west corner.")


def write_generated(path: Path, seed: int, *, size: Sequence[float] | None = None,
                    overwrite: bool = False, option: str = "path") -> Scenario:
    """Write :func:`generate`'s site to ``path`` (a ``.toml`` file), and load it back.

    The scenario is named after the file's stem, as the shipped ones are. An existing file is
    replaced only with ``overwrite``; ``option`` names ``path`` in that refusal (``--out``).

    Returns:
        The scenario loaded from the file written.

    Raises:
        InvalidInputError: A bad argument, named, a path that does not end in ``.toml``, or
            an existing file without ``overwrite``.
        ScenarioError: The file does not load back to the same data (a bug in the writer).
    """
    path = Path(path)
    if path.suffix != ".toml":
        raise InvalidInputError(f"path must name a .toml file, got {str(path)!r}")
    data = generate_data(seed, size=size, name=path.stem)
    claim_file(path, overwrite, option)
    write_file(prepare_folder(path.parent) / path.name, _text(seed, size, data))
    scenario = load_scenario(path)
    if _read_toml(path) != data:
        raise ScenarioError(f"{path}: the file written does not read back as the generated data")
    return scenario


def generate_data(seed: int, *, size: Sequence[float] | None = None,
                  name: str | None = None) -> dict[str, Any]:
    """:func:`generate`'s site as parsed-TOML data (what ``tomllib`` reads from its file)."""
    seed = whole_number("seed", seed, minimum=0)
    sides = _checked_size(size)
    name = _checked_name(seed, name)
    rng = dict(zip(_STREAMS, map(np.random.default_rng, np.random.SeedSequence(seed).spawn(
        len(_STREAMS))), strict=True))
    if sides is None:
        sides = (draw(rng["room"], SIDE, 0.5), draw(rng["room"], SIDE, 0.5))
    plan = draw_plan(rng["racks"], sides)
    beacons = beacons_data(plan, rng["beacons"])
    racks = racks_data(plan)
    data = {"name": name, "description": _description(seed, plan, racks, beacons),
            "version": GENERATOR_VERSION, "room": {"bounds": plan.bounds},
            **_sensor_tables(rng["sensor"]), "walls": walls_data(plan, rng["walls"]),
            "racks": racks, "beacons": beacons, "lights": lights_data(plan, rng["lights"]),
            "bumps": bumps_data(plan, rng["bumps"]), "routes": routes_data(plan, rng["routes"])}
    return {key: value for key, value in data.items() if value != []}  # no empty [[bumps]]


def _sensor_tables(rng: np.random.Generator) -> dict[str, Any]:
    """The ``[error_model]``, ``[camera]`` and ``[faults]`` tables."""
    return {"error_model": {"center_error_px": draw(rng, CENTER_ERROR_PX, 0.05),
                            "horizon_radius_px": draw(rng, HORIZON_RADIUS_PX, 10.0),
                            "coverage": True},
            "camera": {"height": draw(rng, CAMERA_HEIGHT), "min_elevation_deg": 0.0,
                       "max_range": draw(rng, CAMERA_RANGE, 1.0)},
            "faults": {"misdecode_rate": draw(rng, MISDECODE_RATE, 0.001)}}


def _description(seed: int, plan: Plan, racks: list[dict[str, Any]],
                 beacons: list[dict[str, Any]]) -> str:
    """One line: the room, its racks and beacons."""
    heights = [rack["height"] for rack in racks]
    x_max, y_max = plan.bounds[2:]
    return (f"generated warehouse (seed {seed}): {x_max:g} m x {y_max:g} m, {len(racks)} racks "
            f"({min(heights):g}-{max(heights):g} m), {len(beacons)} beacons")


def _checked_size(size: Sequence[float] | None) -> tuple[float, float] | None:
    """``size`` as two sides in ``SIDE_LIMITS`` [m], or None."""
    if size is None:
        return None
    low, high = SIDE_LIMITS
    try:
        sides = tuple(size) if not isinstance(size, (str, bytes)) else ()
    except TypeError:
        sides = ()
    if len(sides) != 2 or not all(isinstance(s, numbers.Real) and not isinstance(s, bool)
                                  and math.isfinite(s) and low <= s <= high for s in sides):
        raise InvalidInputError(f"size must be two sides (east-west, north-south) from {low:g} "
                                f"to {high:g} m, got {size!r}")
    return float(sides[0]), float(sides[1])


def _checked_name(seed: int, name: str | None) -> str:
    """``name``, or ``generated-<seed>``; a name is a plain file name, as in a file."""
    if name is None:
        return f"generated-{seed}"
    problem = name_problem(name) if isinstance(name, str) else "must be a string"
    if problem:
        raise InvalidInputError(f"name {problem}")
    return name


def _read_toml(path: Path) -> dict[str, Any]:
    """A file's TOML data."""
    with path.open("rb") as file:
        return tomllib.load(file)
