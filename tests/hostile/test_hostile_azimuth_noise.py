"""An azimuth noise too small to weigh azimuths by is refused by name, not met by a crash.

With Δα_d at 1e-9 rad and no extra noise or coverage term, gated-ekf's and robust's gate
inverted a matrix singular to machine precision on warehouse-small's first frames and raised
numpy's ``LinAlgError`` out of ``tracker.update``. Both noises below 1e-6 rad (0.2″, finer than any
camera measures azimuths) are now refused when the tracker (or a survey's settings) is made.
"""

from __future__ import annotations

import dataclasses

import pytest

import azgym
from azgym import InvalidInputError
from azgym.mapping.problem import Settings
from azgym.site.error_model import LEAST_AZIMUTH_NOISE
from azgym.world.drive import simulate


@pytest.mark.parametrize("spec", ["gated-ekf", "robust"])
@pytest.mark.parametrize("delta_alpha_d", [0.0, 1e-9])
def test_a_tracker_without_azimuth_noise_is_refused_by_name(spec, delta_alpha_d):
    with pytest.raises(InvalidInputError, match="delta_alpha_d .* extra_sigma .* below 1e-06 rad"):
        azgym.make_tracker(spec, delta_alpha_d=delta_alpha_d, extra_sigma=0.0, coverage=False)


def test_a_survey_without_azimuth_noise_is_refused_by_name():
    settings = Settings()
    with pytest.raises(InvalidInputError, match="survey settings: delta_alpha_d"):
        dataclasses.replace(settings, delta_alpha_d=1e-9, extra_sigma=0.0)


def test_at_the_least_noise_a_route_is_tracked_to_its_end_without_a_crash():
    scenario = azgym.load_scenario("warehouse-small")
    frames = list(simulate(scenario, "aisle-loop", seed=7))[:60]
    tracker = azgym.make_tracker("gated-ekf", delta_alpha_d=LEAST_AZIMUTH_NOISE,
                                 extra_sigma=0.0, coverage=False)
    tracker.reset(seed=0, initial=frames[0].pose)
    for frame in frames:
        tracker.predict(frame.motion)
        tracker.update(frame.measurements, scenario.beacons)
