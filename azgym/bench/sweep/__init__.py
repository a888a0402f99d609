"""``azgym sweep``: localizers x hyperparameter grids x suites x seeds, from a TOML file.

``config`` reads and checks the sweep's file; ``run`` runs every grid point through the one
runner and writes one table, the runtimes and one figure.
"""
