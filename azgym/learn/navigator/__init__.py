"""Training navigators with stable-baselines3 (``azgym train navigator``, the ``rl`` extra).

``request`` a training run with every argument checked, ``train`` the run itself (environments,
evaluations, checkpoints, the final policy scored), ``card`` its model card and learning curve,
``hyperparams.yml`` the hyperparameters per environment id. The shipped policies and the loading
of policy files are :mod:`azgym.nav.policy_file`'s.
"""
