"""Benchmark suites, the runner and the leaderboard."""
