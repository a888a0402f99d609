"""Learned localizers: training data from generated warehouses, features, weights, networks.

Nothing here is imported by ``import azgym``. :mod:`~azgym.learn.dataset` draws frames from
procedurally generated warehouses (train and held-out splits by generator seed);
:mod:`~azgym.learn.features` turns a frame's usable measurements into the per-measurement
features that training and serving share. Training needs the ``train`` extra (torch); serving
runs on numpy and numba only.
"""
