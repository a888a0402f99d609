"""Argument checks shared by the environments."""

from __future__ import annotations

import math

from azgym.errors import InvalidInputError


def check_render_mode(render_mode: str | None, modes: list[str]) -> None:
    """Refuse an unknown render mode, and "human" where no window can be opened."""
    if render_mode is not None and render_mode not in modes:
        raise InvalidInputError(f"render_mode must be one of {modes}, got {render_mode!r}")
    if render_mode == "human":
        from azgym.envs.render import require_display

        require_display()


def reward_weights(**weights: float) -> dict[str, float]:
    """The weights of named reward terms, each a finite number >= 0."""
    for name, value in weights.items():
        if isinstance(value, bool) or not (isinstance(value, (int, float))
                                           and math.isfinite(value) and value >= 0):
            raise InvalidInputError(f"{name} weight must be a number >= 0, got {value!r}")
    return {name: float(value) for name, value in weights.items()}
