"""Rátosi & Simon (2021), Sec. 3, reproduced: the paper suite through the runner, and a report."""

__all__ = ["bound", "report", "reproduce"]
