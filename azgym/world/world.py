"""A scenario's warehouse as a pymunk space: static racks and walls, and the forklift."""

from __future__ import annotations

from dataclasses import dataclass

import pymunk

from azgym.site import Scenario
from azgym.world.forklift import FORKLIFT_COLLISION_TYPE, Forklift, ForkliftSpec

__all__ = ["PHYSICS_DT", "WALL_THICKNESS", "Contact", "World"]

PHYSICS_DT = 0.02
"""The world's physics step [s]."""
STATIC_COLLISION_TYPE = 2
WALL_THICKNESS = 0.1


@dataclass(frozen=True)
class Contact:
    """A collision of the forklift with a rack or a wall, as recorded (never acted on).

    Attributes:
        step: The world step in which it began.
        obstacle: "rack" or "wall", and its index in the scenario, e.g. ("rack", 3).
    """

    step: int
    obstacle: tuple[str, int]


class World:
    """Racks and walls as static pymunk shapes, and a :class:`Forklift` that drives among them.

    Args:
        scenario: The site.
        start: The forklift's start pose (x, y, heading) [m, m, rad].
        spec: The forklift's dimensions and limits.
        dt: The physics step [s].
    """

    def __init__(self, scenario: Scenario, start: tuple[float, float, float],
                 spec: ForkliftSpec | None = None, dt: float = PHYSICS_DT) -> None:
        self.scenario = scenario
        self.dt = dt
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)
        static = self.space.static_body
        self._obstacle_of: dict[pymunk.Shape, tuple[str, int]] = {}
        for k, rack in enumerate(scenario.racks):
            shape: pymunk.Shape = pymunk.Poly(static, [tuple(corner) for corner in rack.corners()])
            self._add_static(shape, ("rack", k))
        for k, wall in enumerate(scenario.walls):
            shape = pymunk.Segment(static, wall.start, wall.end, WALL_THICKNESS / 2)
            self._add_static(shape, ("wall", k))
        self.forklift = Forklift(self.space, spec or ForkliftSpec(), *start)
        self.steps = 0
        self.contacts: list[Contact] = []
        self.space.on_collision(FORKLIFT_COLLISION_TYPE, STATIC_COLLISION_TYPE,
                                begin=self._record_contact)

    def _add_static(self, shape: pymunk.Shape, obstacle: tuple[str, int]) -> None:
        shape.collision_type = STATIC_COLLISION_TYPE
        shape.friction = 0.8
        self.space.add(shape)
        self._obstacle_of[shape] = obstacle

    def _record_contact(self, arbiter: pymunk.Arbiter, _space: pymunk.Space, _data: object) -> None:
        # Only record: what a collision means (a penalty, the end of an episode) is decided by
        # whoever steps the world, never inside the physics callback.
        static_shape = arbiter.shapes[1]
        self.contacts.append(Contact(self.steps, self._obstacle_of[static_shape]))

    def step(self, throttle: float, steer: float) -> None:
        """Advance the world by one physics step with the given controls (see Forklift.command)."""
        self.forklift.command(throttle, steer, self.dt)
        self.steps += 1
        self.space.step(self.dt)

    @property
    def time(self) -> float:
        """Simulated time since the start [s]."""
        return self.steps * self.dt
