"""Sensors by name: the one place where a camera model is chosen (``sensor=``, ``ids=``)."""

from __future__ import annotations

from collections.abc import Callable

from azgym.errors import InvalidInputError, unknown_name
from azgym.registry import Registry
from azgym.sensing.identities import ID_MODES
from azgym.sensing.protocol import Sensor
from azgym.site import Scenario

__all__ = ["SENSORS", "make_sensor"]

SENSORS: Registry[Callable[..., Sensor]] = Registry("sensor", {
    "geometry": "azgym.sensing.geometry.sensor:GeometrySensor",
    "image": "azgym.sensing.image.sensor:ImageSensor",
})
"""The camera models: the compiled geometry, or rendered and detected fisheye frames (each
imported when first made)."""


def make_sensor(scenario: Scenario, sensor: str = "geometry", ids: str = "oracle") -> Sensor:
    """The camera model of that name for the scenario.

    Args:
        scenario: The site.
        sensor: "geometry" (the compiled geometry, ids read at the scenario's misread rate) or
            "image" (fisheye frames rendered and detected).
        ids: For the image sensor: "oracle" or "blink" (see :mod:`azgym.sensing.image.sensor`).

    Raises:
        UnknownNameError: An unknown sensor or id mode.
        InvalidInputError: Blinking ids without the image sensor.
    """
    SENSORS.check_name(sensor)
    if not isinstance(ids, str) or ids not in ID_MODES:
        raise unknown_name("ids", str(ids), ID_MODES)
    if sensor == "geometry":
        if ids == "blink":
            raise InvalidInputError('ids="blink" needs the image path: sensor="image"')
        return SENSORS.make(sensor, scenario=scenario)
    return SENSORS.make(sensor, scenario=scenario, ids=ids)
