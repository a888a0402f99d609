"""Experiments on top of the benchmark: the paper's reproduction and the studies of the models."""

__all__ = ["error_model", "identification", "paper", "plotter"]
