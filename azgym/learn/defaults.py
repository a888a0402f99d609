"""The training defaults of each learned localizer, written once for the library and the command.

``azgym train localizer`` and :func:`azgym.learn.train.train_ng_ransac` /
:func:`azgym.learn.train_regression.train_learned` take them from here, and the command's help
quotes them; this module imports nothing heavy, so the command's parser can read it.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["FRAMES_PER_LAYOUT", "MODEL_DEFAULTS", "ModelDefaults"]

FRAMES_PER_LAYOUT = 100
"""Frames drawn in each generated warehouse (its held-out frames too)."""


@dataclass(frozen=True)
class ModelDefaults:
    """What a model trains on and for how long, unless told.

    Attributes:
        layouts: Generated warehouses trained on.
        epochs: Passes over the frames.
        hidden: Width of the network's hidden layers.
    """

    layouts: int
    epochs: int
    hidden: int


MODEL_DEFAULTS = {"ng-ransac": ModelDefaults(layouts=64, epochs=20, hidden=16),
                  "learned": ModelDefaults(layouts=1000, epochs=60, hidden=32)}
"""Each model's defaults (the shipped weights' settings for ``learned``; ng-ransac's shipped
weights used 400 layouts)."""
