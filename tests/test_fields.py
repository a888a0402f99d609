"""The one rule for a number field and the field reader every config file is read with."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from azgym.errors import InvalidInputError, ScenarioError
from azgym.fields import FLAG, Fields, Flag, Number, argument_error, require

SHARE = Number(0.0, 1.0, high_open=True, unit="rad")


@pytest.mark.parametrize(("rule", "value", "problem"), [
    (Number(), True, "must be a finite number, got True"),
    (Number(), math.nan, "must be a finite number, got nan"),
    (Number(), -math.inf, "must be a finite number, got -inf"),
    (Number(), "1", "must be a finite number, got '1'"),
    (SHARE, "1", "must be a finite number [rad], got '1'"),
    (SHARE, 1.0, "must be in [0, 1) rad, got 1.0"),
    (SHARE, -0.01, "must be in [0, 1) rad, got -0.01"),
    (Number(0.0, low_open=True), 0, "must be > 0, got 0"),
    (Number(0.0), -1, "must be >= 0, got -1"),
    (Number(high=5.0, high_open=True), 5, "must be < 5, got 5"),
    (Number(high=5.0), 6, "must be <= 5, got 6"),
    (Number(0.0, cap=1e5), 10**400, "must be <= 100000, got 1000000000"),
    (Number(cap=1e5), -1e300, "must be in [-100000, 100000], got -1e+300"),
    (Number(1, 4, integer=True), 2.0, "must be an integer in [1, 4], got 2.0"),
    (Number(1, 4, integer=True), False, "must be an integer in [1, 4], got False"),
    (Number(1, 4, integer=True), 5, "must be an integer in [1, 4], got 5"),
    (Number(integer=True), 0.5, "must be an integer, got 0.5"),
    (FLAG, 1, "must be true or false, got 1"),
])
def test_a_refused_value_is_worded_by_the_rule(rule: Number, value: object, problem: str) -> None:
    got = rule.problem(value)
    assert got is not None and got.startswith(problem)


@pytest.mark.parametrize(("rule", "value"), [
    (SHARE, 0), (SHARE, 0.999), (Number(0.0, low_open=True), 1e-300), (Number(cap=1e5), -1e5),
    (Number(1, 4, integer=True), 4), (Number(), 10**400), (FLAG, False),
])
def test_a_valid_value_has_no_problem(rule: Number, value: object) -> None:
    assert rule.problem(value) is None


def test_a_reader_raises_the_problem_named_by_file_and_field() -> None:
    read = Fields("room.toml", error=ScenarioError)
    assert read.number(3, "racks[0].height", Number(0.0, low_open=True)) == 3.0
    assert read.integer(7, "version", 1, 9) == 7
    assert read.boolean(False, "quick") is False
    with pytest.raises(ScenarioError, match=r"^room\.toml: racks\[0\]\.height: must be > 0, "):
        read.number(-1, "racks[0].height", Number(0.0, low_open=True))
    with pytest.raises(InvalidInputError, match=r"^quick: must be true or false, got 'yes'$"):
        Fields().boolean("yes", "quick")


def test_a_collecting_reader_reports_every_problem_and_goes_on() -> None:
    found: list[str] = []
    read = Fields(report=found.append)
    assert not read.check(math.nan, "sensor.delta_alpha_d", SHARE)
    assert not read.check("no", "sensor.coverage", FLAG)
    assert read.check(0.5, "sensor.delta_alpha_d", SHARE)
    assert found == ["sensor.delta_alpha_d: must be a finite number [rad], got nan",
                     "sensor.coverage: must be true or false, got 'no'"]


def test_unknown_keys_are_worded_as_every_unknown_name_and_all_reported():
    found: list[str] = []
    fields = Fields("log.toml", report=found.append)
    assert not fields.keys({"rate_hz": 1, "rat_hz": 2, "colour": 3}, {"rate_hz", "description"},
                           "camera")
    assert found == [
        "log.toml: camera: unknown key 'rat_hz'. Did you mean 'rate_hz'? Valid keys: "
        "description, rate_hz.",
        "log.toml: camera: unknown key 'colour'. Valid keys: description, rate_hz."]


def test_an_unknown_key_raises_without_a_report_and_a_huge_one_is_cut():
    with pytest.raises(InvalidInputError, match=r"^sweep: unknown key 'seed'\. Did you mean "
                                                r"'seeds'\?"):
        Fields("sweep").keys({"seed": 1}, {"seeds"})
    with pytest.raises(InvalidInputError) as raised:
        Fields("sweep").keys({"k" * 1_000_000: 1}, {"seeds"})
    assert len(str(raised.value)) < 200 and f"'{'k' * 37}...'" in str(raised.value)


GATE = Number(0.0, low_open=True, infinite=True)


@pytest.mark.parametrize(("rule", "value", "problem"), [
    (Number(), np.float64(math.nan), "must be a finite number, got "),
    (Number(), np.bool_(True), "must be a finite number, got "),
    (Number(integer=True), np.float64(2.0), "must be an integer, got "),
    (Number(1, 4, integer=True), np.int64(5), "must be an integer in [1, 4], got "),
    (Number(0.0), np.float32(-0.5), "must be >= 0, got "),
    (GATE, -math.inf, "must be a finite number or inf, got -inf"),
    (GATE, math.nan, "must be a finite number or inf, got nan"),
    (GATE, 0, "must be > 0, got 0"),
    (Number(high=5.0, infinite=True), math.inf, "must be <= 5, got inf"),
    (Number(infinite=True, integer=True), math.inf, "must be an integer, got inf"),
    (Number(0, 2**31, high_open=True, integer=True), 2**31,
     "must be an integer in [0, 2147483648), got 2147483648"),
    (Flag(python=True), 1, "must be True or False, got 1"),
    (FLAG, np.bool_(True), "must be true or false, got "),
])
def test_numpy_scalars_and_infinity_are_worded_by_the_same_rule(rule, value, problem):
    got = rule.problem(value)
    assert got is not None and got.startswith(problem)


@pytest.mark.parametrize(("rule", "value"), [
    (SHARE, np.float32(0.5)), (SHARE, np.int8(0)), (Number(1, 4, integer=True), np.uint64(4)),
    (GATE, math.inf), (GATE, np.float64(math.inf)), (GATE, 10**400),
    (Flag(python=True), np.bool_(False)), (Flag(python=True), True),
])
def test_numpy_scalars_and_a_let_through_infinity_are_values(rule, value):
    assert rule.problem(value) is None


def test_a_huge_integer_is_compared_exactly_never_as_a_float():
    assert str(Number(high=1e300).problem(10**400)).startswith("must be <= 1e+300, got 1000")
    assert Number(high=2.0**53).problem(2**53 + 1) is not None  # equal as floats
    assert Number(high=2**53, integer=True).problem(np.int64(2**53 + 1)) is not None
    assert Number(0.0, cap=1e5).problem(-(10**400)) is not None


def test_an_argument_is_worded_after_its_name_without_a_colon():
    workers = functools.partial(argument_error, "workers")
    with pytest.raises(InvalidInputError, match=r"^workers must be an integer >= 1, got 1\.5$"):
        require(1.5, Number(1, integer=True), workers)
    assert str(argument_error("", "must be > 0, got 0")) == "must be > 0, got 0"
    assert Number(1, integer=True).as_int(np.int64(3), workers) == 3
    assert type(Number(1, integer=True).as_int(np.int64(3), workers)) is int
    assert type(Number().as_float(np.float32(0.5), workers)) is float
    assert type(Fields().integer(np.int16(7), "version", 1, 9)) is int


def test_a_huge_integer_is_refused_when_made_a_float_not_overflowing() -> None:
    with pytest.raises(ValueError, match="must be a number within a float's range, got 10000"):
        Number(0.0).as_float(10**400, ValueError)
    assert Number(0.0).as_float(10**300, ValueError) == 1e300
