"""The fisheye image path: lights rendered, blobs detected, ids identified or decoded.

``render`` draws the lights, ``detect`` finds the blobs, ``blink_code`` is the on-off code beacons
send their ids in, ``blob_tracker`` follows blobs across frames and decodes it, and ``sensor``
(``ImageSensor``) puts them together.
"""

__all__ = ["blink_code", "blob_tracker", "detect", "render", "sensor"]
