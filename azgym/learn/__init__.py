"""Learned localizers: models trained in PyTorch on generated warehouses, served in numpy."""
