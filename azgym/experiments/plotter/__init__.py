"""Plotter's simulation (Dang et al. 2015) reproduced with azgym's trackers; see docs/plotter.md."""

from azgym.experiments.plotter.figure import PLOTTER_FILES, write_figure, write_outputs
from azgym.experiments.plotter.reproduce import reproduce_plotter

__all__ = ["PLOTTER_FILES", "reproduce_plotter", "write_figure", "write_outputs"]
