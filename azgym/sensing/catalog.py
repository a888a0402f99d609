"""Sensors by name: the one place where a camera model is chosen (``sensor=``, ``ids=``)."""

from __future__ import annotations

from azgym.errors import InvalidInputError, unknown_name
from azgym.sensing.identities import ID_MODES
from azgym.sensing.protocol import Sensor
from azgym.site import Scenario

__all__ = ["SENSORS", "make_sensor"]

SENSORS = ("geometry", "image")
"""The camera models: the compiled geometry, or rendered and detected fisheye frames."""


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
    if not isinstance(sensor, str) or sensor not in SENSORS:
        raise unknown_name("sensor", str(sensor), SENSORS)
    if not isinstance(ids, str) or ids not in ID_MODES:
        raise unknown_name("ids", str(ids), ID_MODES)
    if sensor == "geometry":
        if ids == "blink":
            raise InvalidInputError('ids="blink" needs the image path: sensor="image"')
        from azgym.sensing.geometry.sensor import GeometrySensor

        return GeometrySensor(scenario)
    from azgym.sensing.image.sensor import ImageSensor

    return ImageSensor(scenario, ids=ids)
