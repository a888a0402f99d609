"""Importing azgym does no work: no heavy library, and the environment ids register on demand."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


def test_import_azgym_loads_no_heavy_library():
    loaded = run("import sys, azgym; print(sorted(m for m in ('gymnasium', 'pymunk', 'cv2', "
                 "'numba', 'scipy', 'matplotlib', 'torch') if m in sys.modules))")
    assert loaded == "[]"


def test_environment_ids_register_with_the_environments_package_in_either_order():
    make = ("env = gym.make('azgym/Localize-WarehouseSmall-v1'); "
            "print(type(env.unwrapped).__name__)")
    assert run("import azgym.envs; import gymnasium as gym; " + make) == "LocalizeEnv"
    assert run("import gymnasium as gym; import azgym.envs; " + make) == "LocalizeEnv"
    assert run("import gymnasium as gym, azgym; " + make) == "LocalizeEnv"  # Gymnasium first
    assert run("import azgym; print(len(azgym.ENV_IDS))") == "11"
    # Gymnasium's own "module:id" form imports the package itself.
    assert run("import azgym, gymnasium as gym; env = gym.make('azgym.envs:azgym/Localize-"
               "WarehouseSmall-v1'); print(type(env.unwrapped).__name__)") == "LocalizeEnv"


def test_import_azgym_leaves_the_import_machinery_alone():
    assert run("import sys; finders = list(sys.meta_path); import azgym, gymnasium; "
               "print(sys.meta_path == finders)") == "True"


def test_the_public_surface_reaches_the_benchmark():
    assert run("import azgym; print(azgym.get_suite('paper').name, azgym.run_benchmark.__name__, "
               "azgym.Contender.__name__)") == "paper run_benchmark Contender"
    assert {"Contender", "get_suite", "run_benchmark"} <= set(
        run("import azgym; print(' '.join(azgym.__all__))").split())


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


def test_every_package_is_installed_and_the_scenarios_with_it():
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "azgym").rglob(
        "__init__.py")}
    assert set(setuptools["packages"]) == folders | {"azgym.site.scenarios"}
    assert setuptools["package-dir"] == {"azgym.site.scenarios": "envs"}
    assert not (ROOT / "azgym" / "site" / "scenarios").exists()  # one copy: the repository's envs/
    shipped = run("from importlib import resources; print(sorted(p.name for p in resources.files("
                  "'azgym.site.scenarios').iterdir() if p.name.endswith('.toml')))")
    assert shipped == str(sorted(p.name for p in (ROOT / "envs").glob("*.toml")))


def test_the_build_requires_what_compiling_the_kernels_imports_at_the_dependencies_bounds():
    # The build runs the default benchmark (azgym.build_hook); a bound that drifted from the
    # dependencies' would compile with one version and run with another.
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    requires = [r for r in project["build-system"]["requires"] if not r.startswith("setuptools")]
    assert requires and set(requires) <= set(project["project"]["dependencies"])
    assert project["tool"]["setuptools"]["cmdclass"] == {"build_py": "azgym.build_hook.BuildPy"}
