"""The mapping run's table and file: mappers ranked by the beacon error's tail, every case kept."""

from __future__ import annotations

import dataclasses
import json
import math

from mapping_files import hand_result

from azgym.bench.mapping.report import (
    COLUMNS,
    MAPPING_FILE,
    case_record,
    rank_key,
    score_table,
    write_mapping,
)
from azgym.bench.mapping.scoring import MapperSummary


def test_the_table_ranks_by_the_p95_so_the_stale_map_is_last_despite_its_median():
    result = hand_result()
    prior, rays = result.summaries["prior"], result.summaries["rays"]
    assert prior.error_median_cm < rays.error_median_cm and math.isinf(prior.error_p95_cm)
    lines = score_table(result.summaries.values()).splitlines()
    assert lines[0].split()[:4] == ["#", "mapper", "median", "cm"]
    assert [line.split()[:2] for line in lines[1:]] == [["1", "rays"], ["2", "prior"]]
    # prior: an infinite p95 and worst, no precision (it said nothing moved), a worst delay of
    # inf (a moved beacon seen and never said moved)
    prior_cells = lines[2].split()[2:]
    assert prior_cells[:6] == ["0.0", "inf", "inf", "0.0", "-", "0"]
    assert prior_cells[7] == "inf"


def test_a_missing_figure_ranks_last_and_names_break_ties():
    summary = hand_result().summaries["rays"]
    nan = dataclasses.replace(summary, mapper="a", error_p95_cm=math.nan)
    same = dataclasses.replace(summary, mapper="b")
    assert sorted([nan, summary, same], key=rank_key) == [same, summary, nan]


def test_the_columns_name_summary_fields():
    fields = {field.name for field in dataclasses.fields(MapperSummary)}
    assert {key for _, key, _ in COLUMNS} <= fields


def test_the_file_keeps_each_case_with_inf_as_null_and_one_case_a_line(tmp_path):
    result = hand_result()
    path = write_mapping(result, tmp_path)
    assert path == tmp_path / MAPPING_FILE
    text = path.read_text()
    data = json.loads(text)
    assert [m["mapper"] for m in data["mappers"]] == ["prior", "rays"]
    assert data["cases"] == list(result.cases)
    prior = data["mappers"][0]
    assert prior["cases"] == [case_record(score) for score in result.scores["prior"]]
    assert prior["cases"][0]["beacons"][0] == {"beacon": 3, "error": None, "placed": False}
    assert prior["summary"]["error_p95_cm"] is None  # inf: JSON has none
    assert "Infinity" not in text and "NaN" not in text
    assert sum(line.startswith('   {"case": ') for line in text.splitlines()) == 8


def test_the_file_is_the_same_for_the_same_run_but_its_timestamp(tmp_path):
    result = hand_result()
    one = json.loads(write_mapping(result, tmp_path / "one").read_text())
    two = json.loads(write_mapping(result, tmp_path / "two").read_text())
    one.pop("timestamp"), two.pop("timestamp")
    assert one == two
