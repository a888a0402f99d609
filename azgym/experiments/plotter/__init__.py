"""Plotter's simulation (Dang et al. 2015) reproduced with azgym's trackers; see docs/plotter.md."""

from azgym.experiments.plotter.figure import write_figure
from azgym.experiments.plotter.reproduce import reproduce_plotter

__all__ = ["reproduce_plotter", "write_figure"]
