"""What the localizers' compiled kernels share: the layout of their pose arrays and flags.

Kernels work on plain arrays of *usable* measurements — azimuths ``az`` (K,) in the camera frame,
the horizontal positions ``bx, by`` (K,) of the beacons they were decoded as, and the beacon
widths ``width`` (K,) — so the Python side (validation, id lookup) stays out of the hot loops.
They hand poses to each other as small float arrays whose slots are named here, once: a start
pose, a triplet's answer, and the refinement's output, which continues with its cost, iterations
and status (and ransac's output continues that, with the ``OUT_*`` slots of ``ransac.py``). Also
here: the fastmath flag set for loops over many candidates.

The kernels themselves live in modules of their own: angle arithmetic in ``_angles``, the
triplet circles (eq. 7-20) in ``_circles``, the refinement (eq. 28-33) in
``_levenberg_marquardt``. Kernels freeze these constants when compiled, so this module is hashed
with the kernel modules (``azgym.jit.KERNEL_MODULES``) to keep numba's cache fresh.
"""

from __future__ import annotations

VECTOR_MATH = {"reassoc", "nsz", "arcp", "contract"}
"""numba ``fastmath`` flags for loops over many candidates (ransac's scoring, mex's grid rows).

Reassociation lets LLVM vectorise such a loop (4 values at a time); the sums then depend on the
compiled code, which is fixed for a machine, so results stay bit-for-bit repeatable.
"""

# Pose arrays (a start pose, a triplet's or the refinement's answer) hold (x, y, cos φ, sin φ) in
# these slots; the refinement's output (``_levenberg_marquardt.refine``) continues with its cost,
# iterations and status. Every reader and writer indexes them by name, so the layout is stated
# here once.
POSE_X = 0
"""Slot of a pose array: the camera's x [m]."""
POSE_Y = 1
"""Slot of a pose array: the camera's y [m]."""
POSE_COS = 2
"""Slot of a pose array: cos φ of the heading φ."""
POSE_SIN = 3
"""Slot of a pose array: sin φ."""
POSE_SIZE = 4
"""Length of a pose array."""
REFINED_COST = POSE_SIZE
"""Slot of the refinement's output: the final cost Σ w_i ε_i² [rad²]."""
REFINED_ITERATIONS = POSE_SIZE + 1
"""Slot of the refinement's output: the number of Levenberg-Marquardt iterations."""
REFINED_STATUS = POSE_SIZE + 2
"""Slot of the refinement's output: CONVERGED, MAX_ITER, SINGULAR or ON_BEACON."""
REFINED_SIZE = POSE_SIZE + 3
"""Length of the refinement's output (``_levenberg_marquardt.refine``)."""

# Status codes of the refinement (kept as ints so the kernels stay simple).
CONVERGED = 0
"""Refinement status: a step no longer changed the pose or the cost, or none lowered the cost."""
MAX_ITER = 1
"""Refinement status: stopped at the iteration limit before converging."""
SINGULAR = 2
"""Refinement status: the measurements used do not determine the pose at the answer."""
ON_BEACON = 3
"""Refinement status: the answer is on a beacon it used, where that beacon's azimuth is undefined
(set by ``refinement.refine_with_covariance``)."""
