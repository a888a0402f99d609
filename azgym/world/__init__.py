"""The physical warehouse: a pymunk space with racks and walls, and a forklift that drives in it."""
