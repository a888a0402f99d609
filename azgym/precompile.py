"""Compiling azgym's kernels while azgym is installed, so that its first run compiles nothing.

numba compiles a kernel on its first call, and azgym's take about twenty seconds together:
without this, a fresh installation's first ``azgym bench`` would spend most of its time there.
The installation's build (:mod:`azgym.build_hook`) runs ``python -m azgym.precompile OUT`` on a
copy of the package, with an empty ``NUMBA_CACHE_DIR``. That runs what a first run compiles —
the default ``azgym bench``, every built-in localizer and tracker through the benchmark's
warm-up route, a short episode of each kind of environment and frames of the fisheye image
path — and copies numba's cached kernels into ``OUT`` (the package's
:data:`azgym.jit.COMPILED_FOLDER`), one subfolder per source folder, with a manifest of the
sources' digest and the numba version. At import, :mod:`azgym.jit` copies them into the
folder numba caches in when both still match.

The kernels are machine code for the processor the installation was built on (numba compiles
for the host), as numba's own cache is; numba checks that too before it loads one.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numba
import numpy as np

from azgym.jit import (
    MANIFEST_NAME,
    PACKAGE_DIR,
    kernel_folders,
    numba_subfolder,
    sources_digest,
)

__all__ = ["collect", "compile_all", "main"]


def compile_all(scratch: Path) -> None:
    """Run everything whose kernels a first run compiles (numba caches them as it goes).

    Args:
        scratch: A folder for the benchmark run's results (deleted by the caller).
    """
    from azgym.bench.run.worker import warm_up
    from azgym.cli import main as azgym_command
    from azgym.localize.registry import list_localizers, list_trackers
    from azgym.track.base import make_tracker

    status = azgym_command(["bench", "--out", str(scratch / "bench")])
    if status != 0:
        raise RuntimeError(f"azgym bench exited with status {status}")
    for name in [*list_localizers(), *list_trackers()]:
        warm_up(make_tracker(name))
    _step_environments()
    _observe_images()


def _step_environments() -> None:
    """A short random episode of each kind of environment.

    A first Navigate step compiles the world's, the planner's and the observation's kernels:
    half a minute without this.
    """
    import gymnasium

    from azgym.envs import ENV_IDS

    kinds = {env_id.split("/")[-1].split("-")[0]: env_id for env_id in ENV_IDS}
    for env_id in kinds.values():
        env = gymnasium.make(env_id)
        env.reset(seed=0)
        env.action_space.seed(0)
        for _ in range(40):
            if any(env.step(env.action_space.sample())[2:4]):
                env.reset()
        env.close()


def _observe_images() -> None:
    """Frames of the fisheye image path, with ids by the oracle and by blinking."""
    from azgym.sensing.image.sensor import ImageSensor
    from azgym.site import load_scenario
    from azgym.world.drive import camera_trajectory

    scenario = load_scenario("warehouse-small")
    poses = camera_trajectory(scenario, scenario.routes[0], camera_rate_hz=30.0)
    for ids in ("oracle", "blink"):
        sensor = ImageSensor(scenario, ids=ids)
        sensor.reset(0)
        rng = np.random.default_rng(0)
        for pose in poses[:20]:
            sensor.observe(tuple(pose), rng)


def collect(cache: Path, out: Path, package_dir: Path = PACKAGE_DIR) -> int:
    """Copy azgym's kernels from numba's cache folder into ``out``, with their manifest.

    ``out`` is replaced as a whole (it is the build's own folder): the new one is written beside
    it and renamed into place.

    Args:
        cache: The ``NUMBA_CACHE_DIR`` the kernels were compiled into.
        out: The folder to write (``azgym/_compiled`` of the package being built).
        package_dir: The package the kernels were compiled from.

    Returns:
        How many cached kernels (index files) were copied.
    """
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    kernels = 0
    for sources in kernel_folders(package_dir):
        compiled = cache / numba_subfolder(sources)
        if not compiled.is_dir():
            continue
        target = staging / sources.relative_to(package_dir)
        target.mkdir(parents=True, exist_ok=True)
        for path in sorted(compiled.glob("*.nb[ic]")):
            shutil.copyfile(path, target / path.name)
            kernels += path.suffix == ".nbi"
    manifest = {"sources": sources_digest(package_dir), "numba": numba.__version__}
    (staging / MANIFEST_NAME).write_text(json.dumps(manifest, indent=1) + "\n")
    if out.exists():
        shutil.rmtree(out)
    staging.rename(out)
    return kernels


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m azgym.precompile OUT``: compile every kernel and write them into OUT."""
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) != 1 or not os.environ.get("NUMBA_CACHE_DIR"):
        print("usage: NUMBA_CACHE_DIR=EMPTY-FOLDER python -m azgym.precompile OUT",
              file=sys.stderr)
        return 2
    out = Path(args[0]).resolve()
    with tempfile.TemporaryDirectory(prefix="azgym-precompile-") as scratch:
        compile_all(Path(scratch))
    kernels = collect(Path(os.environ["NUMBA_CACHE_DIR"]), out)
    print(f"azgym: {kernels} compiled kernels written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
