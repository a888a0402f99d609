"""Navigation: the planner on the known map, the scripted driver, training and scoring."""
