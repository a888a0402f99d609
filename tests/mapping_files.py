"""Mapping results made by hand: a run of the quick mapping suite's cases, its file, its forgeries.

The figures are invented but keep every rule a mapping file obeys (the scoring's and the
suite's), so a test can change one of them and see it refused; no mapper is run.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from azgym.bench.mapping.scoring import (
    BeaconScore,
    CaseScore,
    MappingResult,
    MovedScore,
    summarize,
)
from azgym.bench.mapping.suites import MAPPING_SUITES, case_names

FRAMES = 12
"""Frames of each invented case."""


def case_score(name: str, mapper: str, k: int) -> CaseScore:
    """An invented score of ``mapper`` on the case ``name`` (the ``k``-th of the suite).

    ``prior`` places nothing: on the ``unknown`` case its beacons have no position (inf).
    ``rays`` places every beacon within centimetres and finds the moved one 2 s after it was
    seen; on ``unchanged`` it says one beacon moved, falsely.
    """
    scenario, route, perturbation = name.split("/")
    ids = [3, 5, 8, 13]
    placed = mapper != "prior"
    if placed:
        errors = [0.01 * (j + 1) + 0.001 * k for j in range(len(ids))]
    elif perturbation == "unknown":
        errors = [math.inf] * len(ids)
    else:
        errors = [0.0, 0.0, 0.5 if perturbation != "unchanged" else 0.0, 0.0]
    beacons = tuple(BeaconScore(i, e, placed) for i, e in zip(ids, errors, strict=True))
    moved = (MovedScore(8, placed, 4.5, 2.0 if placed else None),) \
        if perturbation in ("moved", "rack") else ()
    said = ((8,) if moved else (13,) if perturbation == "unchanged" else ()) if placed else ()
    true = tuple(0.02 + 0.001 * f for f in range(FRAMES))
    updated = tuple(math.inf if f == 0 and not placed else e + (0.0 if placed else 0.03)
                    for f, e in enumerate(true))
    return CaseScore(name, scenario, route, perturbation, beacons, moved, said,
                     len(set(said) - {m.beacon for m in moved}), updated, true, None, 0,
                     0.25 + 0.01 * k)


def hand_result(mappers: tuple[str, ...] = ("prior", "rays")) -> MappingResult:
    """An invented run of ``mappers`` on the quick mapping suite's cases, summaries and all."""
    suite = MAPPING_SUITES["mapping"]
    names = tuple(case_names(True))
    scores = {mapper: tuple(case_score(name, mapper, k) for k, name in enumerate(names))
              for mapper in mappers}
    return MappingResult(suite.name, suite.version, "dev", suite.dev_seed, True, 60.0, mappers,
                         names, scores, {mapper: summarize(mapper, scores[mapper])
                                         for mapper in mappers}, 1.0)


def edited(path: Path, out: Path, edit: Callable[[dict[str, Any]], object]) -> Path:
    """A copy of the mapping file ``path`` at ``out``, its data changed by ``edit`` first."""
    data = json.loads(path.read_text())
    edit(data)
    out.write_text(json.dumps(data))
    return out
