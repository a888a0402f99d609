"""A mapping results file read back: what the run wrote reads as it was, and the reader's
rules are the scoring's and the suite's (the attacks are in tests/hostile/)."""

from __future__ import annotations

import dataclasses
import math

import pytest
from mapping_files import edited, hand_result

from azgym.bench.mapping.report import write_mapping
from azgym.bench.mapping.results_file import CASE_CHECKS, is_mapping_file, load_mapping
from azgym.bench.mapping.scoring import CaseScore
from azgym.bench.mapping.suites import MAPPING_SUITES, case_names


def test_a_written_run_reads_back_as_it_was_scored(tmp_path):
    result = hand_result()
    checked = load_mapping(write_mapping(result, tmp_path))
    assert checked.scores == result.scores  # inf back from null, tuples back from lists
    for mapper, summary in result.summaries.items():
        assert dataclasses.asdict(checked.summaries[mapper]).keys() == \
            dataclasses.asdict(summary).keys()
        for key, value in dataclasses.asdict(summary).items():
            again = dataclasses.asdict(checked.summaries[mapper])[key]
            assert again == value or (math.isnan(again) and math.isnan(value)), key


def test_every_field_of_a_case_score_has_its_check():
    assert list(CASE_CHECKS) == [field.name for field in dataclasses.fields(CaseScore)]


def test_a_mapping_file_is_told_from_other_files(tmp_path):
    path = write_mapping(hand_result(), tmp_path)
    assert is_mapping_file(path)
    navigation = edited(path, tmp_path / "other.json", lambda d: d.update(kind="navigation"))
    assert not is_mapping_file(navigation)
    (tmp_path / "broken.json").write_text("{")
    assert not is_mapping_file(tmp_path / "broken.json")


@pytest.mark.slow
def test_the_case_names_are_the_ones_the_suite_draws():
    suite = MAPPING_SUITES["mapping"]
    assert case_names(True) == [case.name for case in suite.build(suite.dev_seed, True)]
