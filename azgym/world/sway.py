"""The camera's sway on bumpy floor: pitch and roll of a damped mast that the bumps shake.

The camera sits on the forklift's overhead guard. On a bumpy stretch the floor shakes it and it
sways like a damped oscillator: for each of pitch and roll, x'' + 2ζω x' + ω² x = w(t), with
natural frequency ω = 2π f and damping ratio ζ from the forklift's spec, driven by white noise
w(t) while the forklift is on a bump and by nothing elsewhere. The noise's intensity is the one
that makes x's stationary standard deviation the bump's ``tilt``; off the bump the sway rings
down within about 1 / (ζω) seconds. So consecutive frames see nearly the same tilt (at 30 Hz
and f = 2 Hz, frame-to-frame changes are about 0.4 × tilt), as a real camera does, instead of
independent draws that would throw every blob several pixels each frame.

The process is advanced exactly at the frame period (a linear stochastic system's exact
discretization): the state (x, x') goes to Φ (x, x') + e with Φ = exp(A T) and e normal with
covariance Q = P∞ − Φ P∞ Φᵀ, where P∞ = tilt² diag(1, ω²) is the stationary covariance.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.errors import InvalidInputError
from azgym.site import Scenario
from azgym.world.forklift import ForkliftSpec

__all__ = ["CameraSway"]


class CameraSway:
    """Pitch and roll of the camera, frame by frame (see the module).

    Args:
        scenario: Where the bumps are.
        frame_period: Time between frames [s]; ``step`` advances the sway by this much.
        spec: The forklift, for its sway frequency and damping (default :class:`ForkliftSpec`).
    """

    def __init__(self, scenario: Scenario, frame_period: float,
                 spec: ForkliftSpec | None = None) -> None:
        if not (math.isfinite(frame_period) and frame_period > 0):
            raise InvalidInputError(f"frame_period must be > 0 s, got {frame_period!r}")
        from scipy.linalg import expm  # imported here: 0.13 s that a run without sway never pays

        spec = spec or ForkliftSpec()
        omega = 2.0 * math.pi * spec.sway_hz
        drift = np.array([[0.0, 1.0], [-omega**2, -2.0 * spec.sway_damping * omega]])
        self._bumps = scenario.bumps
        self._transition = expm(drift * frame_period)
        stationary = np.diag([1.0, omega**2])  # P∞ for a unit tilt
        unit_noise = stationary - self._transition @ stationary @ self._transition.T
        self._noise_factor = np.linalg.cholesky(unit_noise)
        self._state = np.zeros((2, 2))  # rows: angle, rate; columns: pitch, roll
        self._still = True  # the state is zero: it stays so until a bump

    def reset(self) -> None:
        """Still camera: no sway, as at the start of an episode."""
        self._state[:] = 0.0
        self._still = True

    def step(self, x: float, y: float, rng: np.random.Generator) -> tuple[float, float]:
        """Advance one frame with the camera at (x, y); returns the new (pitch, roll) [rad].

        The bump at (x, y), if any, shakes the mast during the frame; off bumps no random number
        is drawn.
        """
        tilt = next((bump.tilt for bump in self._bumps if bump.contains(x, y)), 0.0) \
            if self._bumps else 0.0
        if self._still and tilt <= 0.0:
            return 0.0, 0.0
        self._state = self._transition @ self._state
        if tilt > 0.0:
            self._still = False
            self._state += tilt * (self._noise_factor @ rng.standard_normal((2, 2)))
        return float(self._state[0, 0]), float(self._state[0, 1])
