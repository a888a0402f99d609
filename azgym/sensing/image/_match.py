"""Which light made each blob, compiled (:class:`~azgym.sensing.image.sensor.ImageSensor`).

Each blob takes the light whose projected centre is nearest, if within that light's reach. As
numpy calls (the lights' directions, the fisheye's projection, a blob-by-light distance table)
it cost about 90 µs a frame; one loop here. In a module of its own so that the kernel cache
depends on nothing else.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit

__all__ = ["nearest_lights"]


@jit
def nearest_lights(pixels, azimuth, elevation, half_width, half_tall, cx, cy, focal, distortion,
                   match_px, source):
    """Each blob's light (its row), or −1, into ``source``.

    A light's centre is its direction (``azimuth``, ``elevation`` in the camera frame [rad])
    through the fisheye (:meth:`~azgym.site.fisheye.FisheyeCamera.project`: θ = atan2(ρ, z),
    the image radius f · θ (1 + k₁θ² + k₂θ⁴ + k₃θ⁶ + k₄θ⁸)); its reach is ``match_px`` plus its
    own half-size on the image, the larger of its half-width [rad] times its image radius and
    its half-height [rad] times the focal length ``focal`` [px], (``cx``, ``cy``) the principal
    point [px]. A blob (a row of ``pixels``, (u, v) [px]) takes the nearest centre (the first of
    equals) if it is within that light's reach.
    """
    k1, k2, k3, k4 = distortion[0], distortion[1], distortion[2], distortion[3]
    count = azimuth.size
    centre_u = np.empty(count)
    centre_v = np.empty(count)
    reach = np.empty(count)
    for light in range(count):
        c = math.cos(elevation[light])
        x = c * math.cos(azimuth[light])
        y = c * math.sin(azimuth[light])
        theta = math.atan2(math.hypot(x, y), math.sin(elevation[light]))
        t2 = theta * theta
        radius = focal * (theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))))
        direction = math.atan2(y, x)
        centre_u[light] = cx + radius * math.cos(direction)
        centre_v[light] = cy + radius * math.sin(direction)
        on_image = math.hypot(centre_u[light] - cx, centre_v[light] - cy)
        reach[light] = match_px + max(on_image * half_width[light], focal * half_tall[light])
    for blob in range(pixels.shape[0]):
        best, nearest = -1, math.inf
        for light in range(count):
            distance = math.hypot(pixels[blob, 0] - centre_u[light],
                                  pixels[blob, 1] - centre_v[light])
            if distance < nearest:
                best, nearest = light, distance
        source[blob] = best if best >= 0 and nearest <= reach[best] else -1
