"""Benchmark suites: fixed, versioned sets of cases that every contender is scored on."""

from azgym.bench.suites.base import CAUSES, Case, Suite, frame_cause
from azgym.bench.suites.catalog import SUITES, get_suite

__all__ = ["CAUSES", "SUITES", "Case", "Suite", "frame_cause", "get_suite"]
