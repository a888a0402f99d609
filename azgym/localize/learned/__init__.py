"""The learned localizers as they serve: ``ng-ransac`` and ``learned``, their networks and weights.

Everything here runs on numpy and numba; none of it imports torch. Training lives above, in
:mod:`azgym.learn`, and writes what this package reads:

- :mod:`~azgym.localize.learned.features`: the per-measurement features, one compiled kernel
  that training and serving share;
- :mod:`~azgym.localize.learned.inlier_network` (:class:`InlierScorer`) and
  :mod:`~azgym.localize.learned.pose_network` (:class:`PoseRegressor`): the networks' compiled
  forward passes;
- :mod:`~azgym.localize.learned.weights`: the model files (``.npz``), their reader, writer and
  checks, and :data:`MODELS`, the folder of the shipped weights and their model cards;
- :mod:`~azgym.localize.learned.distribution`: the training distribution a model file records
  (:class:`TrainingDistribution`) and the refusal of frames outside it;
- :mod:`~azgym.localize.learned.ng_ransac` (:class:`NgRansac`, its compiled search in
  ``ng_search``) and :mod:`~azgym.localize.learned.pose_regression` (:class:`Learned`): the
  localizers, registered as ``ng-ransac`` and ``learned``.
"""

from azgym.localize.learned.distribution import TrainingDistribution
from azgym.localize.learned.inlier_network import InlierScorer
from azgym.localize.learned.ng_ransac import SHIPPED_WEIGHTS as NG_RANSAC_WEIGHTS
from azgym.localize.learned.ng_ransac import NgRansac
from azgym.localize.learned.pose_network import PoseRegressor
from azgym.localize.learned.pose_regression import SHIPPED_WEIGHTS as LEARNED_WEIGHTS
from azgym.localize.learned.pose_regression import Learned
from azgym.localize.learned.weights import MODELS, load_weights, model_path, save_weights

__all__ = ["LEARNED_WEIGHTS", "MODELS", "NG_RANSAC_WEIGHTS", "InlierScorer", "Learned", "NgRansac",
           "PoseRegressor", "TrainingDistribution", "load_weights", "model_path", "save_weights"]
