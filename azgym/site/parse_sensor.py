"""The sensor's tables: ``[camera]``, ``[fisheye]``, ``[error_model]`` and ``[faults]``.

These describe the forklift's camera rather than the room: where it is mounted and what it can
see, its lens, how wrong its angles are and how often it misreads an id. Each is optional and
falls back to its class's defaults, and none depends on the layout, so they are read apart from
the floor's tables (:mod:`azgym.site.parse_layout`); field-level checks and their messages are
in :mod:`azgym.site.reader`.
"""

from __future__ import annotations

import math
from typing import Any

from azgym.errors import InvalidInputError
from azgym.site.elements import ALL_ROUND, CAMERA_RATES_HZ, Camera, Faults
from azgym.site.error_model import ErrorModel
from azgym.site.fisheye import MAX_IMAGE_SIDE, FisheyeCamera
from azgym.site.reader import Reader, shown

__all__ = ["parse_camera", "parse_error_model", "parse_faults", "parse_fisheye"]

_CAMERA_KEYS = {"height", "min_elevation_deg", "max_range", "field_of_view_deg", "rate_hz"}
_FISHEYE_KEYS = {"focal_px", "principal_point", "image_size", "distortion"}
_ERROR_KEYS = {"delta_alpha_d_deg", "center_error_px", "horizon_radius_px", "coverage"}
_FAULT_KEYS = {"misdecode_rate"}


def parse_camera(read: Reader, table: Any) -> Camera:
    """The ``[camera]`` table: height, elevation limit, range, field of view and frame rate.

    Each defaults to :class:`Camera`'s (an upward fisheye seeing all round at 10 Hz).
    """
    read.table(table, "camera", _CAMERA_KEYS)
    default = Camera()
    elevation = read.number(table.get("min_elevation_deg", math.degrees(default.min_elevation)),
                            "camera.min_elevation_deg")
    if not -90.0 < elevation < 90.0:
        raise read.fail("camera.min_elevation_deg", f"must be in (-90, 90), got {elevation}")
    view = read.number(table.get("field_of_view_deg", math.degrees(default.field_of_view)),
                       "camera.field_of_view_deg", positive=True)
    if view > 360.0:
        raise read.fail("camera.field_of_view_deg", f"must be in (0, 360] (360: all round), "
                        f"got {view}")
    low, high = CAMERA_RATES_HZ
    rate = read.number(table.get("rate_hz", default.rate_hz), "camera.rate_hz", positive=True)
    if not low <= rate <= high:
        raise read.fail("camera.rate_hz", f"must be from {low:g} to {high:g} [Hz], got {rate}")
    return Camera(
        height=read.number(table.get("height", default.height), "camera.height", positive=True),
        min_elevation=math.radians(elevation),
        max_range=read.number(table.get("max_range", default.max_range), "camera.max_range",
                              positive=True),
        field_of_view=ALL_ROUND if view == 360.0 else math.radians(view),
        rate_hz=rate,
    )


def parse_fisheye(read: Reader, table: Any) -> FisheyeCamera:
    """The ``[fisheye]`` table: intrinsics, each defaulting to :class:`FisheyeCamera`'s."""
    read.table(table, "fisheye", _FISHEYE_KEYS)
    default = FisheyeCamera()
    size = table.get("image_size", list(default.image_size))
    if not (isinstance(size, list) and len(size) == 2):
        raise read.fail("fisheye.image_size", f"must be [width, height] in pixels, got "
                        f"{shown(size)}")
    size = [read.integer(side, f"fisheye.image_size[{k}]", minimum=1, maximum=MAX_IMAGE_SIDE)
            for k, side in enumerate(size)]
    point = read.vector(table.get("principal_point", list(default.principal_point)),
                        "fisheye.principal_point", 2)
    distortion = read.vector(table.get("distortion", list(default.distortion)),
                             "fisheye.distortion", 4)
    focal = read.number(table.get("focal_px", default.focal_px), "fisheye.focal_px")
    try:
        return FisheyeCamera(focal_px=focal, principal_point=(point[0], point[1]),
                             image_size=(size[0], size[1]),
                             distortion=(distortion[0], distortion[1], distortion[2],
                                         distortion[3]))
    except InvalidInputError as exc:  # it names the field; add the file
        field = str(exc).split(" ", 1)[0].replace("FisheyeCamera.", "fisheye.")
        raise read.fail(field, str(exc).split(" ", 1)[1]) from None


def parse_error_model(read: Reader, table: Any) -> ErrorModel:
    """The ``[error_model]`` table: Δα_d in degrees, or the camera's pixel errors (eq. 1)."""
    read.table(table, "error_model", _ERROR_KEYS)
    coverage = read.boolean(table.get("coverage", True), "error_model.coverage")
    camera_keys = {"center_error_px", "horizon_radius_px"} & set(table)
    if camera_keys and "delta_alpha_d_deg" in table:
        raise read.fail("error_model.delta_alpha_d_deg",
                        "give either delta_alpha_d_deg or center_error_px + horizon_radius_px")
    if camera_keys:
        center = read.number(read.require(table, "center_error_px", "error_model."),
                             "error_model.center_error_px", non_negative=True)
        radius = read.number(read.require(table, "horizon_radius_px", "error_model."),
                             "error_model.horizon_radius_px", positive=True)
        return ErrorModel.from_camera(center, radius, coverage=coverage)
    degrees = read.number(table.get("delta_alpha_d_deg", 0.4), "error_model.delta_alpha_d_deg",
                          non_negative=True, below=90.0)
    return ErrorModel(delta_alpha_d=math.radians(degrees), coverage=coverage)


def parse_faults(read: Reader, table: Any) -> Faults:
    """The ``[faults]`` table: the misread rate of oracle ids, in [0, 1]."""
    read.table(table, "faults", _FAULT_KEYS)
    return Faults(misdecode_rate=read.fraction(table.get("misdecode_rate", 0.0),
                                               "faults.misdecode_rate"))
