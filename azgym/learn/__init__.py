"""Training: the learned localizers' networks on generated warehouses, and the navigator's policy.

Nothing here is imported by ``import azgym``, nor by anything that serves: the localizers' served
half (the features, the networks' compiled forward passes, the weight files, the training
distribution, the shipped models and the localizers) is :mod:`azgym.localize.learned`, which
this package imports and writes for. :mod:`~azgym.learn.dataset` draws frames from procedurally
generated warehouses (train and held-out splits by generator seed); :mod:`~azgym.learn.train`
and :mod:`~azgym.learn.train_regression` fit the networks in torch (the ``train`` extra) and
export their weights; :mod:`~azgym.learn.calibrate` sets ng-ransac's answer test. The
navigator's trainer is :mod:`azgym.learn.navigator`.
"""
