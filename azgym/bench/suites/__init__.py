"""Benchmark suites: fixed, versioned sets of cases that every contender is scored on."""

from azgym.bench.suites.base import CAUSES, NO_TEST_SPLIT, Case, Suite, frame_cause
from azgym.bench.suites.catalog import SUITES, get_suite

__all__ = ["CAUSES", "NO_TEST_SPLIT", "SUITES", "Case", "Suite", "frame_cause", "get_suite"]
