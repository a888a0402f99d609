"""The physical warehouse: a pymunk space with racks and walls, and a forklift that drives in it."""

__all__ = ["drive", "driver", "forklift", "motion_sensors", "robot", "robot_figures", "sway",
           "world"]
