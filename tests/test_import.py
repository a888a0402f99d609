"""Importing azgym does no work: no heavy library, and the environment ids register on demand."""

from __future__ import annotations

import subprocess
import sys


def run(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


def test_import_azgym_loads_no_heavy_library():
    loaded = run("import sys, azgym; print(sorted(m for m in ('gymnasium', 'pymunk', 'cv2', "
                 "'numba', 'scipy', 'matplotlib', 'torch') if m in sys.modules))")
    assert loaded == "[]"


def test_environment_ids_register_whether_gymnasium_comes_first_or_second():
    make = ("env = gym.make('azgym/Localize-WarehouseSmall-v1'); "
            "print(type(env.unwrapped).__name__)")
    assert run("import gymnasium as gym, azgym; " + make) == "LocalizeEnv"
    assert run("import azgym; import gymnasium as gym; " + make) == "LocalizeEnv"
    assert run("import azgym; print(len(azgym.ENV_IDS))") == "11"
    # A library probing whether Gymnasium is installed must not disarm the registration.
    probe = "import azgym, importlib.util; importlib.util.find_spec('gymnasium'); "
    assert run(probe + "import gymnasium as gym; " + make) == "LocalizeEnv"


def test_public_names_resolve_lazily_and_unknown_ones_fail_cleanly():
    assert run("import azgym; print(azgym.make_localizer('ransac').name)") == "ransac"
    assert "has no attribute 'nope'" in subprocess.run(
        [sys.executable, "-c", "import azgym; azgym.nope"], capture_output=True,
        text=True).stderr


def test_the_learned_localizers_are_made_and_run_without_torch():
    loaded = run(
        "import sys, azgym\n"
        "beacons = azgym.load_scenario('paper-room').beacons\n"
        "frame = azgym.Measurements(beacons.ids[:5], [0.1, 1.0, 2.0, -1.0, -2.5])\n"
        "for name in ('ng-ransac', 'learned'):\n"
        "    azgym.make_localizer(name).localize(frame, beacons)\n"
        "print(sorted(m for m in ('torch', 'tqdm', 'matplotlib') if m in sys.modules))")
    assert loaded == "[]"
