"""Render + detect speed of the fisheye image path (issue #6's target: >= 1000 frames/s).

    python baselines/image_speed.py [--frames 500] [--rounds 5]

A 480 x 480 frame with 12 beacons at random azimuths and elevations, a bank of 4 precomputed
noise frames (sigma 2 grey levels), rendered and detected on one core; the least disturbed round
is reported.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from azgym.sensing.fisheye import FisheyeCamera
from azgym.sensing.image import detect, render


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=500)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    camera = FisheyeCamera()
    rng = np.random.default_rng(0)
    count = 12
    azimuth = rng.uniform(-np.pi, np.pi, count)
    elevation = rng.uniform(0.02, 0.5, count)
    half = np.full(count, np.arctan2(0.015, 10.0))
    flux = np.full(count, 3.0)
    bank = [rng.normal(0.0, 2.0, (480, 480)).astype(np.float32) for _ in range(4)]
    detect(render(camera, azimuth - half, azimuth + half, elevation, flux), camera)  # compile
    best = 0.0
    for _ in range(args.rounds):
        start = time.perf_counter()
        for k in range(args.frames):
            image = render(camera, azimuth - half, azimuth + half, elevation, flux, bank[k % 4])
            found = detect(image, camera)
        best = max(best, args.frames / (time.perf_counter() - start))
    print(f"render + detect, 480 x 480, {count} beacons ({len(found)} found): "
          f"{best:.0f} frames/s (target >= 1000)")


if __name__ == "__main__":
    main()
